// PNG encoding of occupancy grids through OpenCV's codec (kept in its own file so only this translation
// unit parses OpenCV's imgcodecs header). The PNG holds the same trinary image as the PGM.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>

#include "grid_pixels.h"
#include "slamcore/occupancy_grid.h"

namespace slamcore {
namespace {

std::uint32_t BigEndian32(const std::string& bytes, std::size_t at) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < 4; ++i) value = (value << 8) | static_cast<unsigned char>(bytes[at + i]);
  return value;
}

}  // namespace

Result<OccupancyGrid> DecodePng(const std::string& bytes, double resolution, double origin_x, double origin_y,
                                double occupied_thresh, double free_thresh, bool negate) {
  RETURN_IF_ERROR(CheckThresholds(occupied_thresh, free_thresh, resolution));
  // Check the IHDR size before decoding so that an absurd header never reaches an allocation.
  if (bytes.size() < 33 || bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0 ||
      bytes.compare(12, 4, "IHDR") != 0) {
    return DataLoss("PNG: not a PNG file (bad signature or IHDR)");
  }
  const std::uint32_t width = BigEndian32(bytes, 16), height = BigEndian32(bytes, 20);
  auto checked = OccupancyGrid::Create(static_cast<int>(std::min<std::uint32_t>(width, kMaxGridSide + 1)),
                                       static_cast<int>(std::min<std::uint32_t>(height, kMaxGridSide + 1)),
                                       resolution, origin_x, origin_y);
  if (!checked.ok()) return Status(checked.status().code(), "PNG: " + checked.status().message());
  cv::Mat image;
  try {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                         const_cast<char*>(bytes.data()));  // NOLINT: imdecode only reads
    image = cv::imdecode(buffer, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    return DataLoss(std::string("PNG: cannot decode: ") + e.what());
  }
  if (image.empty() || image.cols != static_cast<int>(width) || image.rows != static_cast<int>(height)) {
    return DataLoss("PNG: corrupt or truncated image data");
  }
  OccupancyGrid grid = std::move(*checked);
  for (int image_row = 0; image_row < grid.height; ++image_row) {
    const std::uint8_t* pixels = image.ptr<std::uint8_t>(image_row);
    const int row = grid.ImageRowOf(image_row);
    for (int col = 0; col < grid.width; ++col) {
      grid.at(col, row) = CellFromPixel(pixels[col], occupied_thresh, free_thresh, negate);
    }
  }
  return grid;
}

Result<std::string> EncodePng(const OccupancyGrid& grid) {
  if (grid.width <= 0 || grid.height <= 0 ||
      grid.cells.size() != static_cast<std::size_t>(grid.width) * grid.height) {
    return InvalidArgument("PNG: grid is empty or its cells do not match width x height");
  }
  cv::Mat image(grid.height, grid.width, CV_8UC1);
  for (int image_row = 0; image_row < grid.height; ++image_row) {
    std::uint8_t* pixels = image.ptr<std::uint8_t>(image_row);
    const int row = grid.ImageRowOf(image_row);
    for (int col = 0; col < grid.width; ++col) pixels[col] = PixelFromCell(grid.at(col, row));
  }
  std::vector<std::uint8_t> encoded;
  try {
    if (!cv::imencode(".png", image, encoded)) return Internal("PNG: encoder failed");
  } catch (const cv::Exception& e) {
    return Internal(std::string("PNG: encoder failed: ") + e.what());
  }
  return std::string(encoded.begin(), encoded.end());
}

}  // namespace slamcore
