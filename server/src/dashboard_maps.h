// The three map images of a run's report page (paper Fig. 5 (a)–(c)): the parent map, the rerun child map
// and their difference, rendered exactly as the protrusion detector compared them (analyzer/run_analysis.cc:
// the home component — the parent's largest — in both maps, the parent aligned onto the child's cells), so
// every region's bounding box (child image cells, y down) lands on the same pixels in all three images.
// Internal to server/ (dashboard_routes.cc).
//
// Thread safety: free function without shared state.
#pragma once

#include <string>

#include "storage/repository.h"

namespace server::dashboard {

struct RunMaps {
  std::string parent_png;  // trinary PNG (254 free, 0 occupied, 205 unknown); all unknown on a first run
  std::string child_png;
  std::string difference_png;  // black: new in the child; white: known in both; grey: unknown
  int width = 0, height = 0;   // cells (= pixels) of all three images
  double resolution = 0.0;     // metres per cell
};

/// NOT_FOUND when the run or its report with `parameter_set` is missing; DATA_LOSS when stored bytes do not
/// parse; FAILED_PRECONDITION when the report holds no rerun child map or the child is empty.
storage::Result<RunMaps> RenderRunMaps(storage::Repository& repository, const storage::RunKey& run,
                                       const std::string& parameter_set);

}  // namespace server::dashboard
