#include "daemon/service.hpp"

int main(int argc, char** argv) { return lagrange::RunLagranged(argc, argv); }
