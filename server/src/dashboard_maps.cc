#include "dashboard_maps.h"

#include <set>

#include "analyzer/run_analysis.h"
#include "analyzer/telemetry_codec.h"
#include "fleet/v1/report.pb.h"
#include "slamcore/mapper.h"
#include "slamcore/occupancy_grid.h"
#include "slamcore/protrusion_detector.h"

namespace server::dashboard {
namespace {

using slamcore::NodeId;

// The callee's code, the message prefixed with what was being done.
slamcore::Status WithContext(const slamcore::Status& status, const std::string& what) {
  return {status.code(), what + ": " + status.message()};
}

// A stored record that parses but does not decode is as corrupt as one that does not parse.
slamcore::Status CorruptRecord(const slamcore::Status& status, const std::string& what) {
  return slamcore::DataLoss(what + ": " + status.message());
}

storage::Result<std::string> Png(const slamcore::OccupancyGrid& grid, const std::string& what) {
  auto png = slamcore::EncodePng(grid);
  if (!png.ok()) return WithContext(png.status(), what);
  return std::move(png).value();
}

}  // namespace

storage::Result<RunMaps> RenderRunMaps(storage::Repository& repository, const storage::RunKey& key,
                                       const std::string& parameter_set) {
  const std::string& run_id = key.run_id;
  ASSIGN_OR_RETURN(auto run, repository.GetRun(key));
  ASSIGN_OR_RETURN(auto stored, repository.GetReport(key, parameter_set));
  fleet::v1::RunReport report;
  if (!report.ParseFromString(stored.report))
    return storage::DataLoss("report of run " + run_id + " does not parse");
  if (!report.has_rerun_child())
    return storage::FailedPrecondition("report of run " + run_id + " keeps no child map");
  auto child = analyzer::FromProto(report.rerun_child(), "rerun_child");
  if (!child.ok()) return CorruptRecord(child.status(), "rerun_child");

  slamcore::Map parent;
  if (run.parent_snapshot_id) {
    ASSIGN_OR_RETURN(auto snapshot, repository.GetSnapshot(*run.parent_snapshot_id));
    fleet::v1::MapSnapshot proto;
    if (!proto.ParseFromString(snapshot.bytes)) return storage::DataLoss("parent snapshot does not parse");
    auto decoded = analyzer::FromProto(proto, "parent_snapshot");
    if (!decoded.ok()) return CorruptRecord(decoded.status(), "parent_snapshot");
    parent = std::move(decoded).value();
  }

  auto grids = analyzer::RenderComparedGrids(parent, *child);
  if (!grids.ok()) return WithContext(grids.status(), "maps");
  const slamcore::OccupancyGrid& child_grid = grids->child;
  if (child_grid.width <= 0 || child_grid.height <= 0) {
    return storage::FailedPrecondition("run " + run_id + ": the child map has no local maps to render");
  }
  slamcore::OccupancyGrid aligned;
  if (grids->parent.width > 0) {
    auto shifted = slamcore::AlignParentToChild(grids->parent, child_grid);
    if (!shifted.ok()) return WithContext(shifted.status(), "aligning parent to child");
    aligned = std::move(shifted).value();
  } else {
    auto empty = slamcore::OccupancyGrid::Create(child_grid.width, child_grid.height, child_grid.resolution,
                                                 child_grid.origin_x, child_grid.origin_y);
    if (!empty.ok()) return WithContext(empty.status(), "parent map");
    aligned = std::move(empty).value();
  }
  const std::vector<std::uint8_t> mask = slamcore::DifferenceMask(aligned, child_grid);
  slamcore::OccupancyGrid difference = child_grid;
  for (std::size_t i = 0; i < difference.cells.size(); ++i) {
    const bool known = child_grid.cells[i] != static_cast<std::int8_t>(slamcore::CellState::kUnknown);
    difference.cells[i] =
        static_cast<std::int8_t>(i < mask.size() && mask[i] != 0 ? slamcore::CellState::kOccupied
                                 : known                         ? slamcore::CellState::kFree
                                                                 : slamcore::CellState::kUnknown);
  }

  RunMaps maps;
  maps.width = child_grid.width;
  maps.height = child_grid.height;
  maps.resolution = child_grid.resolution;
  ASSIGN_OR_RETURN(auto parent_png, Png(aligned, "parent map"));
  ASSIGN_OR_RETURN(auto child_png, Png(child_grid, "child map"));
  ASSIGN_OR_RETURN(auto difference_png, Png(difference, "difference map"));
  maps.parent_png = std::move(parent_png);
  maps.child_png = std::move(child_png);
  maps.difference_png = std::move(difference_png);
  return maps;
}

}  // namespace server::dashboard
