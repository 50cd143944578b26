// slamtool subcommands for erroneous-protrusion detection (paper IV-C):
//
//   slamtool protrusions --parent P.yaml --child C.yaml [--model M] [--json] [--png OUT.png]
//                        [--repair cut|parent --repaired OUT.yaml]
//   slamtool make-protrusion-data MAPS_DIR --out DATA [--variants N] [--seed S]
//   slamtool train-protrusions DATA --out MODEL [--classifier auto|decision_tree|random_forest|svm]
//                              [--holdout-homes H1,H2] [--folds K] [--json]
//   slamtool eval-protrusions DATA (--model MODEL [--homes H1,H2] | --leave-one-home-out) [--json]
//
// Exit status: 0 on success, 1 when an input is refused (the message says which and why), 2 on usage.
#pragma once

#include <CLI/CLI.hpp>

void AddProtrusionCommands(CLI::App& app);
