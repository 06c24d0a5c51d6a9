// Running untrusted work (a third-party file importer fed a user's file) in
// a child process: whatever it does - crash, hang, allocate without bound -
// the caller gets an ordinary error, and only the bytes the work returns
// cross back. Linux (fork, pipes, rlimits).
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "quadhand/core/status.h"

namespace quadhand::core {

struct IsolationLimits {
  double seconds = 60.0;                      // wall time before the child is killed
  std::size_t memory_bytes = std::size_t{4} << 30;  // address space of the child (not applied under AddressSanitizer)
};

// Runs `work` in a forked child and returns what it returned. Errors: the
// work's own error (its message as it is), and, starting with `what`, an
// exception it threw, running out of memory within the limit, a crash (the
// signal's name), the time limit, or a failure to start the child. The child only runs `work` and
// writes its result; it never returns into the caller's code.
// Whether this build runs under AddressSanitizer (its shadow memory rules out
// an address-space limit, and it runs several times slower; tests adapt).
bool BuiltWithAddressSanitizer();

Result<std::string> RunIsolated(const std::function<Result<std::string>()>& work, const std::string& what,
                                const IsolationLimits& limits = {});

}  // namespace quadhand::core
