# Per-target settings shared by every QuadHand target. Nothing here touches
# global flags: each target opts in by calling these functions.

# Standard, warnings and optimisation for one target.
function(quadhand_target_settings target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${target} PRIVATE
    $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor>)
endfunction()

# A library under libs/<name> with public headers in include/.
function(quadhand_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(quadhand_${name} ${ARG_SOURCES})
  add_library(quadhand::${name} ALIAS quadhand_${name})
  target_include_directories(quadhand_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_link_libraries(quadhand_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  quadhand_target_settings(quadhand_${name})
endfunction()

# A command-line program, installed into build/bin as quadhand-<name>.
function(quadhand_app name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(quadhand-${name} ${ARG_SOURCES})
  target_link_libraries(quadhand-${name} PRIVATE ${ARG_DEPS})
  quadhand_target_settings(quadhand-${name})
endfunction()
