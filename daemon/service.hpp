#pragma once
// lagranged as a process: options, logging, the three threads, signals.

namespace lagrange {

// main() of lagranged. Exit status: 0 after SIGINT/SIGTERM or --duration;
// 2 for a bad option or scene (named before the loop starts); 3 when
// --require-rt is given and real-time set-up failed; 1 for other failures.
int RunLagranged(int argc, char** argv);

}  // namespace lagrange
