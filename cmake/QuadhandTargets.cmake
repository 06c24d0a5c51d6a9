# Per-target settings shared by every QuadHand target. Nothing here touches
# global flags: each target opts in by calling these functions. Libraries and
# programs are also installed (cmake --install), the libraries as the
# exported targets quadhand::<name> of the CMake package `quadhand`
# (cmake/quadhandConfig.cmake.in).
include(GNUInstallDirs)

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
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(quadhand_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  quadhand_target_settings(quadhand_${name})
  # Position-independent so that the Python module (a shared object) can link
  # the static libraries; without semantic interposition, as the programs'
  # default PIE code, so calls inside a library still inline.
  set_target_properties(quadhand_${name} PROPERTIES EXPORT_NAME ${name} POSITION_INDEPENDENT_CODE ON)
  target_compile_options(quadhand_${name} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-fno-semantic-interposition>)
  install(TARGETS quadhand_${name} EXPORT quadhandTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development)
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/include)
    install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT development)
  endif()
endfunction()

# A command-line program, installed into build/bin as quadhand-<name>.
function(quadhand_app name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(quadhand-${name} ${ARG_SOURCES})
  target_link_libraries(quadhand-${name} PRIVATE ${ARG_DEPS})
  # Where core::FindBundledFile looks last for a default data file.
  target_compile_definitions(quadhand-${name} PRIVATE QUADHAND_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  quadhand_target_settings(quadhand-${name})
  install(TARGETS quadhand-${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT programs)
endfunction()

# A line of CMake code for the installed package's config file, to find a
# dependency that an installed library links (static libraries pass their
# private dependencies on to whoever links them), e.g.
# quadhand_export_dependency("find_dependency(CGAL)").
function(quadhand_export_dependency line)
  set_property(GLOBAL APPEND PROPERTY QUADHAND_EXPORT_DEPENDENCIES "${line}")
endfunction()
