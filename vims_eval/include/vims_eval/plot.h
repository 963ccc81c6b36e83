#pragma once
/// @file plot.h
/// @brief A small 2-D plotting module on OpenCV (no Python, no GUI): line plots, scatter
/// plots, line segments, equal-aspect top views and heat maps / matrices, with axes, ticks,
/// grid, title, legend and colour bar, rendered to a cv::Mat or a PNG file.
///
/// Used for trajectory top views and error curves here, and meant for precision-recall
/// curves, recognition matrices and map views elsewhere. Typical use:
/// @code
///   Plot2D plot(900, 700);
///   plot.setTitle("top view").setAxisLabels("x [m]", "y [m]").setEqualAspect(true);
///   plot.addLine(xs_gt, ys_gt, plotColor(0), "ground truth");
///   plot.addScatter({x0}, {y0}, plotColor(2), "start", 6, MarkerShape::kSquare);
///   plot.savePng("top.png");
/// @endcode
/// Data coordinates are doubles; non-finite points are skipped (and break a line in two,
/// which is how gaps are drawn). Colours are OpenCV BGR scalars.

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>  // cv::COLORMAP_*
#include <string>
#include <vector>

namespace vims {
namespace eval {

/// Colour i of a 10-colour qualitative palette (matplotlib's "tab10"), as BGR; wraps around.
cv::Scalar plotColor(std::size_t i);

enum class MarkerShape { kCircle, kSquare, kTriangle, kCross, kDiamond };
enum class LegendLocation { kTopRight, kTopLeft, kBottomRight, kBottomLeft, kNone };

struct HeatmapStyle {
  int colormap = cv::COLORMAP_VIRIDIS;  ///< any cv::ColormapTypes value
  /// Colour range; when vmin >= vmax the finite minimum / maximum of the data is used.
  double vmin = 0.0;
  double vmax = 0.0;
  bool show_colorbar = true;
  std::string colorbar_label;
  cv::Scalar invalid_color{200, 200, 200};  ///< colour of non-finite cells
};

/// Text rotated 90 degrees counter-clockwise, centred on `center` (vertical axis labels).
void putVerticalText(cv::Mat& canvas, const std::string& text, cv::Point center, double scale);

class Plot2D {
 public:
  explicit Plot2D(int width_px = 900, int height_px = 700);

  Plot2D& setTitle(const std::string& title);
  Plot2D& setAxisLabels(const std::string& x_label, const std::string& y_label);
  /// One data unit is the same number of pixels on both axes (top views, maps).
  Plot2D& setEqualAspect(bool equal);
  /// Fixed axis ranges; without them the range covers all data plus a small margin.
  Plot2D& setXRange(double lo, double hi);
  Plot2D& setYRange(double lo, double hi);
  /// y grows downwards (matrix / image convention: row 0 at the top).
  Plot2D& setInvertY(bool invert);
  Plot2D& setGrid(bool grid);
  Plot2D& setLegendLocation(LegendLocation location);

  /// A polyline through (xs[i], ys[i]); xs and ys must have equal length (std::invalid_argument).
  void addLine(const std::vector<double>& xs, const std::vector<double>& ys, const cv::Scalar& color,
               const std::string& label = "", int thickness_px = 2);
  /// Markers at (xs[i], ys[i]).
  void addScatter(const std::vector<double>& xs, const std::vector<double>& ys, const cv::Scalar& color,
                  const std::string& label = "", int size_px = 4, MarkerShape shape = MarkerShape::kCircle);
  /// Independent segments (x0[i], y0[i]) -> (x1[i], y1[i]), e.g. loop-closure links.
  void addSegments(const std::vector<double>& x0, const std::vector<double>& y0, const std::vector<double>& x1,
                   const std::vector<double>& y1, const cv::Scalar& color, const std::string& label = "",
                   int thickness_px = 1);
  /// A matrix of values (CV_32FC1 or CV_64FC1) drawn as coloured cells covering
  /// [x_min, x_max] x [y_min, y_max]; cell (row r, col c) spans x in [x_min + c dx, x_min + (c+1) dx]
  /// and y in [y_min + r dy, y_min + (r+1) dy]. Row 0 is at y_min, which is the top with
  /// setInvertY(true) (matrix view) and the bottom otherwise (map view). Drawn below lines and
  /// markers; at most one heat map per plot (a second one replaces the first).
  void setHeatmap(const cv::Mat& values, double x_min, double x_max, double y_min, double y_max,
                  const HeatmapStyle& style = HeatmapStyle());

  /// Renders the plot (CV_8UC3, width x height).
  cv::Mat render() const;
  /// Renders and writes a PNG; throws std::runtime_error when the file cannot be written.
  void savePng(const std::string& path) const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  enum class SeriesKind { kLine, kScatter, kSegments };
  struct Series {
    SeriesKind kind = SeriesKind::kLine;
    std::vector<double> xs, ys;    ///< line / scatter points, or segment starts
    std::vector<double> xs1, ys1;  ///< segment ends
    cv::Scalar color;
    std::string label;
    int size_px = 2;  ///< line thickness or marker size
    MarkerShape shape = MarkerShape::kCircle;
  };
  struct Heatmap {
    cv::Mat values;  ///< CV_64FC1
    double x_min = 0, x_max = 1, y_min = 0, y_max = 1;
    HeatmapStyle style;
  };
  struct Range {
    double lo = 0.0, hi = 1.0;
  };
  struct Frame;  // pixel layout and data->pixel mapping of one render

  void dataBounds(Range* x, Range* y) const;
  Frame layout() const;
  void drawHeatmap(cv::Mat& canvas, const Frame& frame) const;
  void drawSeries(cv::Mat& canvas, const Frame& frame) const;
  void drawAxes(cv::Mat& canvas, const Frame& frame) const;
  void drawLegend(cv::Mat& canvas, const Frame& frame) const;

  int width_;
  int height_;
  std::string title_;
  std::string x_label_;
  std::string y_label_;
  bool equal_aspect_ = false;
  bool invert_y_ = false;
  bool grid_ = true;
  bool has_x_range_ = false;
  bool has_y_range_ = false;
  Range x_range_;
  Range y_range_;
  LegendLocation legend_ = LegendLocation::kTopRight;
  std::vector<Series> series_;
  bool has_heatmap_ = false;
  Heatmap heatmap_;
};

/// "Nice" tick positions (steps of 1, 2 or 5 times a power of ten) covering [lo, hi] with
/// about `target_count` ticks; exposed for tests and for callers drawing their own axes.
std::vector<double> niceTicks(double lo, double hi, int target_count = 6);

}  // namespace eval
}  // namespace vims
