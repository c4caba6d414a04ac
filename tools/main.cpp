#include <iostream>

#include "tools/commands.hpp"

int main(int argc, char** argv) { return lagrange::cli::RunLagrangectl(argc, argv, std::cout, std::cerr); }
