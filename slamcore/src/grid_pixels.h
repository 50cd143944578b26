// Internal: the map_server pixel ↔ cell conversions shared by the PGM and PNG codecs.
#pragma once

#include <cstdint>

#include "slamcore/status.h"

namespace slamcore {

/// map_server trinary thresholding of one 0..255 pixel.
std::int8_t CellFromPixel(int pixel, double occupied_thresh, double free_thresh, bool negate);
/// 254 free, 0 occupied, 205 unknown.
std::uint8_t PixelFromCell(std::int8_t cell);
Status CheckThresholds(double occupied_thresh, double free_thresh, double resolution);

}  // namespace slamcore
