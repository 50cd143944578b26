#include "fleet/snapshot_parts.h"

namespace fleet {

std::vector<v1::MapSnapshot> SnapshotParts(const v1::MapSnapshot& snapshot, std::size_t part_bytes) {
  // The first part: every field but the four long lists (so a field added later is not lost).
  std::vector<v1::MapSnapshot> parts(1, snapshot);
  parts.back().clear_nodes();
  parts.back().clear_edges();
  parts.back().clear_views();
  parts.back().clear_local_maps();
  std::size_t size = parts.back().ByteSizeLong();
  // The part an item of `bytes` goes into: a new one when it would take the current one past part_bytes.
  const auto part_for = [&](std::size_t bytes) -> v1::MapSnapshot& {
    constexpr std::size_t kFraming = 6;  // the item's tag and length prefix, at most
    if (size > 0 && size + bytes + kFraming > part_bytes) {
      parts.emplace_back();
      size = 0;
    }
    size += bytes + kFraming;
    return parts.back();
  };
  for (const auto& node : snapshot.nodes()) *part_for(node.ByteSizeLong()).add_nodes() = node;
  for (const auto& edge : snapshot.edges()) *part_for(edge.ByteSizeLong()).add_edges() = edge;
  for (const auto& view : snapshot.views()) *part_for(view.ByteSizeLong()).add_views() = view;
  for (const auto& local_map : snapshot.local_maps())
    *part_for(local_map.ByteSizeLong()).add_local_maps() = local_map;
  return parts;
}

}  // namespace fleet
