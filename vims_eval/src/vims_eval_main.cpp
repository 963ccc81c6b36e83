// vims_eval: trajectory and loop-closure evaluation against ground truth, the ablation study and
// the place-recognition figures. All logic lives in vims_eval_core / vims_eval_paper so that it
// is unit-tested.
#include <iostream>

#include "vims_eval/cli.h"
#ifdef VIMS_EVAL_WITH_PAPER
#include "vims_eval/ablation.h"
#include "vims_eval/map_figures.h"
#endif

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::map<std::string, vims::eval::EvalCommand> extra;
#ifdef VIMS_EVAL_WITH_PAPER
  extra["ablation"] = vims::eval::runAblationCli;
  extra["place-recognition"] = vims::eval::runPlaceRecognitionCli;
  extra["map-size"] = vims::eval::runMapSizeCli;
#endif
  return vims::eval::runEvalCli(args, std::cout, std::cerr, extra);
}
