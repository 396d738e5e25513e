// The reliability diagram (tools/eval/reliability_plot.h): a real PNG file, decoded with
// OpenCV, of the documented layout (up to four panels a row), with one bar per non-empty
// bin as tall as its accuracy; a path that cannot be written is an error naming it.
#include "tools/eval/reliability_plot.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/support/scratch_dir.h"

namespace sceneloc {
namespace {

// The drawing's geometry (reliability_plot.cc): a 320-pixel plot with a 56-pixel margin
// around it, 16 more pixels of caption below; bars in BGR (180, 119, 31).
constexpr int kPlot = 320;
constexpr int kMargin = 56;
constexpr int kCellWidth = kPlot + 2 * kMargin;
constexpr int kCellHeight = kPlot + 2 * kMargin + 16;
const cv::Vec3b kBarColour(180, 119, 31);

// Two answered bins: 0.2-0.3 at accuracy 0.25 and 0.7-0.8 at accuracy 0.75.
ReliabilityPanel TwoBinPanel(const std::string& title) {
  ReliabilityPanel panel;
  panel.title = title;
  panel.metrics.queries = 12;
  panel.metrics.bins[2] = {4, 0.25, 0.25};
  panel.metrics.bins[7] = {8, 0.75, 0.75};
  return panel;
}

// Pixels of the bar colour in column `x` of `image`.
int BarPixelsInColumn(const cv::Mat& image, int x) {
  int n = 0;
  for (int y = 0; y < image.rows; ++y) n += image.at<cv::Vec3b>(y, x) == kBarColour;
  return n;
}

cv::Mat WriteAndRead(const std::vector<ReliabilityPanel>& panels, const std::string& path) {
  const Status written = WriteReliabilityDiagram(panels, path);
  EXPECT_TRUE(written.ok()) << written.ToString();
  return cv::imread(path, cv::IMREAD_COLOR);
}

// Panels sit four to a row: one panel is one cell, five are two rows of four cells.
TEST(ReliabilityPlotTest, WritesAPngOfOneCellPerPanel) {
  const test::ScratchDir dir("plot");
  const cv::Mat one = WriteAndRead({TwoBinPanel("one")}, dir.File("one.png"));
  ASSERT_FALSE(one.empty()) << "not a decodable image";
  EXPECT_EQ(one.cols, kCellWidth);
  EXPECT_EQ(one.rows, kCellHeight);
  EXPECT_EQ(test::ReadFileBytes(dir.File("one.png")).substr(1, 3), "PNG");
  const cv::Mat five =
      WriteAndRead(std::vector<ReliabilityPanel>(5, TwoBinPanel("p")), dir.File("five.png"));
  ASSERT_FALSE(five.empty());
  EXPECT_EQ(five.cols, 4 * kCellWidth);
  EXPECT_EQ(five.rows, 2 * kCellHeight);
  const cv::Mat none = WriteAndRead({}, dir.File("none.png"));
  ASSERT_FALSE(none.empty());
  EXPECT_EQ(none.cols, kCellWidth);
}

// Each answered bin is a bar as tall as its accuracy times the plot; an empty bin draws
// none.
TEST(ReliabilityPlotTest, BarsAreAsTallAsTheAccuracy) {
  const test::ScratchDir dir("plot");
  const cv::Mat image = WriteAndRead({TwoBinPanel("bars")}, dir.File("bars.png"));
  ASSERT_FALSE(image.empty());
  // A column inside each bar, clear of the calibration gap line at the bin's centre.
  const auto column = [](double x) { return kMargin + static_cast<int>(x * kPlot); };
  const int low = BarPixelsInColumn(image, column(0.22));
  const int high = BarPixelsInColumn(image, column(0.72));
  EXPECT_NEAR(low, 0.25 * kPlot, 4);
  EXPECT_NEAR(high, 0.75 * kPlot, 4);
  EXPECT_EQ(BarPixelsInColumn(image, column(0.52)), 0);  // bin 5 is empty
  ReliabilityPanel empty;
  const cv::Mat blank = WriteAndRead({empty}, dir.File("blank.png"));
  ASSERT_FALSE(blank.empty());
  for (const double x : {0.22, 0.52, 0.72}) EXPECT_EQ(BarPixelsInColumn(blank, column(x)), 0);
}

// A folder that does not exist, or a name OpenCV has no writer for, is an IoError naming
// the path.
TEST(ReliabilityPlotTest, UnwritablePathsAreErrors) {
  const test::ScratchDir dir("plot");
  for (const std::string& path : {dir.File("absent/plot.png"), dir.File("plot.unknown")}) {
    const Status status = WriteReliabilityDiagram({TwoBinPanel("x")}, path);
    EXPECT_EQ(status.code(), StatusCode::kIoError) << path;
    EXPECT_NE(status.message().find("'" + path + "'"), std::string::npos) << status.message();
  }
}

}  // namespace
}  // namespace sceneloc
