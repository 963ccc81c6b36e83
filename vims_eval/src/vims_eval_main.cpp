// vims_eval: trajectory and loop-closure evaluation against ground truth.
// All logic lives in vims_eval_core (cli.cpp) so that it is unit-tested.
#include <iostream>

#include "vims_eval/cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return vims::eval::runEvalCli(args, std::cout, std::cerr);
}
