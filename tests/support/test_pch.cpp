// The host of the test programs' precompiled header (lagrange_test_precompiled_header, tests/CMakeLists.txt): a
// program that is never run, so that the header is compiled as the test programs are (-fPIE, their flags).
int main() { return 0; }
