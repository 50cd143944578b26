#include "fleet/snapshot_parts.h"

#include <type_traits>
#include <utility>

namespace fleet {

std::vector<v1::MapSnapshot> SnapshotParts(v1::MapSnapshot snapshot, std::size_t part_bytes) {
  // The four long lists taken out; what remains (every other field, so a field added later is not lost) is
  // the first part.
  const auto take = [](auto* list) {
    std::remove_reference_t<decltype(*list)> taken;
    taken.Swap(list);
    return taken;
  };
  auto nodes = take(snapshot.mutable_nodes());
  auto edges = take(snapshot.mutable_edges());
  auto views = take(snapshot.mutable_views());
  auto local_maps = take(snapshot.mutable_local_maps());
  std::vector<v1::MapSnapshot> parts;
  parts.push_back(std::move(snapshot));
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
  for (auto& node : nodes) *part_for(node.ByteSizeLong()).add_nodes() = std::move(node);
  for (auto& edge : edges) *part_for(edge.ByteSizeLong()).add_edges() = std::move(edge);
  for (auto& view : views) *part_for(view.ByteSizeLong()).add_views() = std::move(view);
  for (auto& local_map : local_maps)
    *part_for(local_map.ByteSizeLong()).add_local_maps() = std::move(local_map);
  return parts;
}

}  // namespace fleet
