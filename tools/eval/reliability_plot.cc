#include "tools/eval/reliability_plot.h"

#include <cstdio>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "common/image/image_codec.h"
#include "common/util/file_io.h"

namespace sceneloc {
namespace {

constexpr int kPanel = 320;  // plot area side, pixels
constexpr int kMargin = 56;  // around each plot
const cv::Scalar kInk(40, 40, 40), kGrid(220, 220, 220), kBar(180, 119, 31), kGap(60, 60, 230);

void Text(cv::Mat* image, const std::string& text, cv::Point at, double scale = 0.4) {
  cv::putText(*image, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, kInk, 1, cv::LINE_AA);
}

void DrawPanel(const ReliabilityPanel& panel, cv::Point origin, cv::Mat* image) {
  const cv::Point o(origin.x + kMargin, origin.y + kMargin + kPanel);  // (0, 0) of the plot
  const auto at = [&](double x, double y) {
    return cv::Point(o.x + static_cast<int>(x * kPanel), o.y - static_cast<int>(y * kPanel));
  };
  for (int i = 0; i <= 10; i += 2) {
    cv::line(*image, at(0, i / 10.0), at(1, i / 10.0), kGrid);
    char label[8];
    std::snprintf(label, sizeof(label), "%.1f", i / 10.0);
    Text(image, label, at(0, i / 10.0) + cv::Point(-30, 4));
    Text(image, label, at(i / 10.0, 0) + cv::Point(-8, 16));
  }
  for (int b = 0; b < 10; ++b) {
    const ReliabilityBin& bin = panel.metrics.bins[static_cast<size_t>(b)];
    if (bin.count == 0) continue;
    cv::rectangle(*image, at(b / 10.0 + 0.01, bin.accuracy), at((b + 1) / 10.0 - 0.01, 0), kBar,
                  cv::FILLED);
    cv::line(*image, at(bin.mean_confidence, bin.accuracy),
             at(bin.mean_confidence, bin.mean_confidence), kGap, 2);
    Text(image, std::to_string(bin.count), at(b / 10.0 + 0.02, std::min(0.97, bin.accuracy + 0.03)),
         0.33);
  }
  cv::line(*image, at(0, 0), at(1, 1), kInk, 1, cv::LINE_AA);
  cv::rectangle(*image, at(0, 1), at(1, 0), kInk);
  Text(image, panel.title, cv::Point(o.x, origin.y + 18), 0.5);
  char caption[160];
  const ConfidenceMetrics& m = panel.metrics;
  std::snprintf(caption, sizeof(caption), "n %d acc %.2f conf %.2f ECE %.3f (floor %.3f)",
                m.queries, m.accuracy, m.mean_confidence, m.ece, m.ece_floor);
  Text(image, caption, cv::Point(o.x - 40, origin.y + 36), 0.36);
  std::snprintf(caption, sizeof(caption), "PR-AUC %.3f  R@100P %.2f   x: confidence, y: accuracy",
                m.pr_auc, m.recall_at_100_precision);
  Text(image, caption, cv::Point(o.x - 40, o.y + 36), 0.36);
}

}  // namespace

Status WriteReliabilityDiagram(const std::vector<ReliabilityPanel>& panels,
                               const std::string& path) {
  const int columns = std::max<int>(1, std::min<int>(4, static_cast<int>(panels.size())));
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  const int cell_w = kPanel + 2 * kMargin, cell_h = kPanel + 2 * kMargin + 16;
  cv::Mat image(std::max(1, rows) * cell_h, columns * cell_w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t i = 0; i < panels.size(); ++i) {
    const int r = static_cast<int>(i) / columns, c = static_cast<int>(i) % columns;
    DrawPanel(panels[i], cv::Point(c * cell_w, r * cell_h), &image);
  }
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension != ".png" && extension != ".PNG") {
    return IoError("cannot write '" + path + "': the reliability diagram is a PNG; name it *.png");
  }
  SCENELOC_ASSIGN_OR_RETURN(const std::string png, EncodePng(image));
  if (Status written = WriteFileAtomically(path, png); !written.ok()) {
    return IoError("cannot write '" + path + "': " + written.message());
  }
  return Status::Ok();
}

}  // namespace sceneloc
