// The detector's picture, laid out like the paper's Fig. 5 (IV-C): parent, child, difference, classes.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "slamcore/protrusion_detector.h"

namespace slamcore {
namespace {

cv::Vec3b Colour(std::int8_t cell) {
  if (cell == static_cast<std::int8_t>(CellState::kFree)) return {254, 254, 254};
  if (cell == static_cast<std::int8_t>(CellState::kOccupied)) return {0, 0, 0};
  return {205, 205, 205};
}

/// A grid as a BGR image in image orientation (row 0 at the top).
cv::Mat ToImage(const OccupancyGrid& grid) {
  cv::Mat image(grid.height, grid.width, CV_8UC3);
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col)
      image.at<cv::Vec3b>(grid.ImageRowOf(row), col) = Colour(grid.at(col, row));
  }
  return image;
}

}  // namespace

Result<std::string> RenderDetectionFigure(const OccupancyGrid& aligned_parent, const OccupancyGrid& child,
                                          const std::vector<ProtrusionRegion>& regions,
                                          const std::vector<bool>& is_protrusion) {
  if (aligned_parent.width != child.width || aligned_parent.height != child.height || child.width <= 0 ||
      regions.size() != is_protrusion.size()) {
    return InvalidArgument("figure: the parent must be aligned to the child, with one class per region");
  }
  if (4LL * child.width * child.height > kMaxGridCells)
    return InvalidArgument("figure: the map is too large to draw");
  const cv::Mat parent_image = ToImage(aligned_parent), child_image = ToImage(child);
  cv::Mat difference(child.height, child.width, CV_8UC3, cv::Scalar(0, 0, 0));
  const std::vector<std::uint8_t> raw = DifferenceMask(aligned_parent, child);
  for (int row = 0; row < child.height; ++row) {
    for (int col = 0; col < child.width; ++col) {
      if (raw[static_cast<std::size_t>(row) * child.width + col]) {
        difference.at<cv::Vec3b>(child.ImageRowOf(row), col) = {110, 110, 110};
      }
    }
  }
  cv::Mat classified = child_image.clone();
  for (std::size_t i = 0; i < regions.size(); ++i) {
    const cv::Vec3b colour = is_protrusion[i] ? cv::Vec3b(40, 40, 230) : cv::Vec3b(60, 190, 60);
    for (const std::int32_t cell : regions[i].cells) {
      const int col = cell % child.width, row = cell / child.width;
      difference.at<cv::Vec3b>(child.ImageRowOf(row), col) = {255, 255, 255};
      classified.at<cv::Vec3b>(child.ImageRowOf(row), col) = colour;
    }
    const ImageBox& box = regions[i].bbox;
    cv::rectangle(classified, cv::Rect(box.x, box.y, box.width, box.height), cv::Scalar(colour), 1);
    cv::putText(classified, std::to_string(regions[i].id), {box.x, std::max(10, box.y - 2)},
                cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(colour), 1);
  }
  cv::Mat figure;
  const cv::Mat gap(child.height, 6, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::hconcat(std::vector<cv::Mat>{parent_image, gap, child_image, gap, difference, gap, classified}, figure);
  std::vector<std::uint8_t> png;
  try {
    if (!cv::imencode(".png", figure, png)) return Internal("figure: PNG encoder failed");
  } catch (const cv::Exception& e) {
    return Internal(std::string("figure: ") + e.what());
  }
  return std::string(png.begin(), png.end());
}

}  // namespace slamcore
