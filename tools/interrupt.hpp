#pragma once
// Ctrl-C for lagrangectl's streaming commands: the first SIGINT asks the
// current command to finish cleanly.

#include <atomic>

namespace lagrange::cli {

// Installs the handler (once) and clears the flag.
void CatchInterrupt();
bool Interrupted();

}  // namespace lagrange::cli
