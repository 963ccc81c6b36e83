#include "vims_eval/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace vims {
namespace eval {
namespace {

const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kGridColor(225, 225, 225);
const cv::Scalar kFrameColor(60, 60, 60);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kTickFontScale = 0.42;
constexpr double kLabelFontScale = 0.52;
constexpr double kTitleFontScale = 0.62;
// Sub-pixel drawing: OpenCV takes fixed-point coordinates with this many fractional bits.
constexpr int kShift = 4;
constexpr double kShiftScale = 1 << kShift;

cv::Point toFixed(const cv::Point2d& p) { return cv::Point(cvRound(p.x * kShiftScale), cvRound(p.y * kShiftScale)); }

bool finite2(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

/// Liang-Barsky clipping of segment a-b to the box [lo, hi]^2 (pixel coordinates). Keeps the
/// fixed-point conversion in range when data lie far outside the visible axes.
bool clipSegment(cv::Point2d* a, cv::Point2d* b, const cv::Point2d& lo, const cv::Point2d& hi) {
  double t0 = 0.0, t1 = 1.0;
  const double dx = b->x - a->x, dy = b->y - a->y;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a->x - lo.x, hi.x - a->x, a->y - lo.y, hi.y - a->y};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0.0) {
      if (q[k] < 0.0) return false;
      continue;
    }
    const double r = q[k] / p[k];
    if (p[k] < 0.0) {
      if (r > t1) return false;
      t0 = std::max(t0, r);
    } else {
      if (r < t0) return false;
      t1 = std::min(t1, r);
    }
  }
  const cv::Point2d a0 = *a;
  *a = a0 + t0 * cv::Point2d(dx, dy);
  *b = a0 + t1 * cv::Point2d(dx, dy);
  return true;
}

std::string formatTick(double v, double step) {
  if (std::abs(v) < step * 1e-9) v = 0.0;  // avoid "-0.0"
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[64];
  if (decimals > 6 || std::abs(v) >= 1e7)
    std::snprintf(buf, sizeof(buf), "%.3g", v);
  else
    std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

cv::Size textSize(const std::string& text, double scale, int* baseline = nullptr) {
  int base = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &base);
  if (baseline) *baseline = base;
  return size;
}

void putText(cv::Mat& canvas, const std::string& text, cv::Point origin, double scale,
             const cv::Scalar& color = kBlack) {
  cv::putText(canvas, text, origin, kFont, scale, color, 1, cv::LINE_AA);
}

void drawMarker(cv::Mat& image, const cv::Point2d& c, int size, MarkerShape shape, const cv::Scalar& color) {
  const double s = std::max(1, size);
  switch (shape) {
    case MarkerShape::kCircle:
      cv::circle(image, toFixed(c), cvRound(s * kShiftScale), color, cv::FILLED, cv::LINE_AA, kShift);
      break;
    case MarkerShape::kSquare:
      cv::rectangle(image, toFixed(c - cv::Point2d(s, s)), toFixed(c + cv::Point2d(s, s)), color, cv::FILLED,
                    cv::LINE_AA, kShift);
      break;
    case MarkerShape::kTriangle: {
      const cv::Point pts[3] = {toFixed(c + cv::Point2d(0, -1.2 * s)), toFixed(c + cv::Point2d(1.1 * s, 0.8 * s)),
                                toFixed(c + cv::Point2d(-1.1 * s, 0.8 * s))};
      cv::fillConvexPoly(image, pts, 3, color, cv::LINE_AA, kShift);
      break;
    }
    case MarkerShape::kDiamond: {
      const cv::Point pts[4] = {toFixed(c + cv::Point2d(0, -1.3 * s)), toFixed(c + cv::Point2d(1.3 * s, 0)),
                                toFixed(c + cv::Point2d(0, 1.3 * s)), toFixed(c + cv::Point2d(-1.3 * s, 0))};
      cv::fillConvexPoly(image, pts, 4, color, cv::LINE_AA, kShift);
      break;
    }
    case MarkerShape::kCross:
      cv::line(image, toFixed(c + cv::Point2d(-s, -s)), toFixed(c + cv::Point2d(s, s)), color, 2, cv::LINE_AA, kShift);
      cv::line(image, toFixed(c + cv::Point2d(-s, s)), toFixed(c + cv::Point2d(s, -s)), color, 2, cv::LINE_AA, kShift);
      break;
  }
}

void checkSameLength(const std::vector<double>& a, const std::vector<double>& b, const char* what) {
  if (a.size() != b.size()) throw std::invalid_argument(std::string("Plot2D::") + what + ": x and y differ in length");
}

}  // namespace

void putVerticalText(cv::Mat& canvas, const std::string& text, cv::Point center, double scale) {
  if (text.empty()) return;
  int baseline = 0;
  const cv::Size size = textSize(text, scale, &baseline);
  cv::Mat horizontal(size.height + baseline + 4, size.width + 4, CV_8UC3, kWhite);
  putText(horizontal, text, cv::Point(2, size.height + 2), scale);
  cv::Mat vertical;
  cv::rotate(horizontal, vertical, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::Rect target(center.x - vertical.cols / 2, center.y - vertical.rows / 2, vertical.cols, vertical.rows);
  const cv::Rect clipped = target & cv::Rect(0, 0, canvas.cols, canvas.rows);
  if (clipped.area() == 0) return;
  vertical(cv::Rect(clipped.x - target.x, clipped.y - target.y, clipped.width, clipped.height)).copyTo(canvas(clipped));
}

cv::Scalar plotColor(std::size_t i) {
  // matplotlib tab10, as BGR.
  static const cv::Scalar kPalette[10] = {{180, 119, 31},  {14, 127, 255}, {44, 160, 44},   {40, 39, 214},
                                          {189, 103, 148}, {75, 86, 140},  {194, 119, 227}, {127, 127, 127},
                                          {34, 189, 188},  {207, 190, 23}};
  return kPalette[i % 10];
}

std::vector<double> niceTicks(double lo, double hi, int target_count) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo || target_count < 1) return ticks;
  const double raw_step = (hi - lo) / target_count;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw_step)));
  const double residual = raw_step / magnitude;
  const double step = magnitude * (residual < 1.5 ? 1.0 : residual < 3.5 ? 2.0 : residual < 7.5 ? 5.0 : 10.0);
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double v = first; v <= hi + step * 1e-9; v += step) ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  return ticks;
}

// ---------------------------------------------------------------------------------------------
// Layout: pixel rectangle of the axes and the data -> pixel mapping.
// ---------------------------------------------------------------------------------------------
struct Plot2D::Frame {
  cv::Rect area;  ///< axes rectangle in canvas pixels
  Range x, y;     ///< visible data ranges
  bool invert_y = false;

  /// Data -> pixel coordinates relative to `area` (the origin is the area's top-left corner).
  cv::Point2d toLocal(double dx, double dy) const {
    const double u = (dx - x.lo) / (x.hi - x.lo) * area.width;
    const double fy = (dy - y.lo) / (y.hi - y.lo);
    const double v = invert_y ? fy * area.height : (1.0 - fy) * area.height;
    return {u, v};
  }
  /// Pixel centre (relative to `area`) -> data coordinates.
  cv::Point2d toData(double u, double v) const {
    const double dx = x.lo + u / area.width * (x.hi - x.lo);
    const double fy = invert_y ? v / area.height : 1.0 - v / area.height;
    return {dx, y.lo + fy * (y.hi - y.lo)};
  }
};

Plot2D::Plot2D(int width_px, int height_px) : width_(width_px), height_(height_px) {
  if (width_px < 200 || height_px < 150) throw std::invalid_argument("Plot2D: the canvas must be at least 200x150 px");
}

Plot2D& Plot2D::setTitle(const std::string& title) {
  title_ = title;
  return *this;
}
Plot2D& Plot2D::setAxisLabels(const std::string& x_label, const std::string& y_label) {
  x_label_ = x_label;
  y_label_ = y_label;
  return *this;
}
Plot2D& Plot2D::setEqualAspect(bool equal) {
  equal_aspect_ = equal;
  return *this;
}
Plot2D& Plot2D::setXRange(double lo, double hi) {
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) throw std::invalid_argument("Plot2D: bad x range");
  x_range_ = {lo, hi};
  has_x_range_ = true;
  return *this;
}
Plot2D& Plot2D::setYRange(double lo, double hi) {
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) throw std::invalid_argument("Plot2D: bad y range");
  y_range_ = {lo, hi};
  has_y_range_ = true;
  return *this;
}
Plot2D& Plot2D::setInvertY(bool invert) {
  invert_y_ = invert;
  return *this;
}
Plot2D& Plot2D::setGrid(bool grid) {
  grid_ = grid;
  return *this;
}
Plot2D& Plot2D::setLegendLocation(LegendLocation location) {
  legend_ = location;
  return *this;
}

void Plot2D::addLine(const std::vector<double>& xs, const std::vector<double>& ys, const cv::Scalar& color,
                     const std::string& label, int thickness_px) {
  checkSameLength(xs, ys, "addLine");
  Series s;
  s.kind = SeriesKind::kLine;
  s.xs = xs;
  s.ys = ys;
  s.color = color;
  s.label = label;
  s.size_px = std::max(1, thickness_px);
  series_.push_back(std::move(s));
}

void Plot2D::addScatter(const std::vector<double>& xs, const std::vector<double>& ys, const cv::Scalar& color,
                        const std::string& label, int size_px, MarkerShape shape) {
  checkSameLength(xs, ys, "addScatter");
  Series s;
  s.kind = SeriesKind::kScatter;
  s.xs = xs;
  s.ys = ys;
  s.color = color;
  s.label = label;
  s.size_px = std::max(1, size_px);
  s.shape = shape;
  series_.push_back(std::move(s));
}

void Plot2D::addSegments(const std::vector<double>& x0, const std::vector<double>& y0, const std::vector<double>& x1,
                         const std::vector<double>& y1, const cv::Scalar& color, const std::string& label,
                         int thickness_px) {
  checkSameLength(x0, y0, "addSegments");
  checkSameLength(x1, y1, "addSegments");
  checkSameLength(x0, x1, "addSegments");
  Series s;
  s.kind = SeriesKind::kSegments;
  s.xs = x0;
  s.ys = y0;
  s.xs1 = x1;
  s.ys1 = y1;
  s.color = color;
  s.label = label;
  s.size_px = std::max(1, thickness_px);
  series_.push_back(std::move(s));
}

void Plot2D::setHeatmap(const cv::Mat& values, double x_min, double x_max, double y_min, double y_max,
                        const HeatmapStyle& style) {
  if (values.empty() || values.channels() != 1 || (values.depth() != CV_32F && values.depth() != CV_64F))
    throw std::invalid_argument("Plot2D::setHeatmap: values must be a non-empty CV_32FC1 or CV_64FC1 matrix");
  if (!(x_max > x_min) || !(y_max > y_min)) throw std::invalid_argument("Plot2D::setHeatmap: empty extent");
  values.convertTo(heatmap_.values, CV_64F);
  heatmap_.x_min = x_min;
  heatmap_.x_max = x_max;
  heatmap_.y_min = y_min;
  heatmap_.y_max = y_max;
  heatmap_.style = style;
  has_heatmap_ = true;
}

void Plot2D::dataBounds(Range* x, Range* y) const {
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  auto include = [&](double px, double py) {
    if (!finite2(px, py)) return;
    x_lo = std::min(x_lo, px);
    x_hi = std::max(x_hi, px);
    y_lo = std::min(y_lo, py);
    y_hi = std::max(y_hi, py);
  };
  for (const auto& s : series_) {
    for (std::size_t i = 0; i < s.xs.size(); ++i) include(s.xs[i], s.ys[i]);
    for (std::size_t i = 0; i < s.xs1.size(); ++i) include(s.xs1[i], s.ys1[i]);
  }
  const bool have_series = std::isfinite(x_lo);
  if (have_series && !has_heatmap_) {
    // A little air around curves so that markers at the extremes stay visible.
    const double pad_x = 0.04 * std::max(x_hi - x_lo, 1e-9);
    const double pad_y = 0.04 * std::max(y_hi - y_lo, 1e-9);
    x_lo -= pad_x;
    x_hi += pad_x;
    y_lo -= pad_y;
    y_hi += pad_y;
  }
  if (has_heatmap_) {
    include(heatmap_.x_min, heatmap_.y_min);
    include(heatmap_.x_max, heatmap_.y_max);
  }
  if (!std::isfinite(x_lo)) {
    x_lo = 0.0, x_hi = 1.0, y_lo = 0.0, y_hi = 1.0;
  }
  // A single point or a constant series still needs a visible span.
  if (x_hi - x_lo < 1e-12) {
    const double half = std::max(0.5, 0.05 * std::abs(x_lo));
    x_lo -= half;
    x_hi += half;
  }
  if (y_hi - y_lo < 1e-12) {
    const double half = std::max(0.5, 0.05 * std::abs(y_lo));
    y_lo -= half;
    y_hi += half;
  }
  *x = {x_lo, x_hi};
  *y = {y_lo, y_hi};
}

Plot2D::Frame Plot2D::layout() const {
  const bool colorbar = has_heatmap_ && heatmap_.style.show_colorbar;
  const int left = 78;
  const int right = colorbar ? 115 : 22;
  const int top = title_.empty() ? 16 : 42;
  const int bottom = x_label_.empty() ? 38 : 58;
  Frame f;
  f.area = cv::Rect(left, top, std::max(10, width_ - left - right), std::max(10, height_ - top - bottom));
  f.invert_y = invert_y_;
  dataBounds(&f.x, &f.y);
  if (has_x_range_) f.x = x_range_;
  if (has_y_range_) f.y = y_range_;
  if (equal_aspect_) {
    // Grow the range that has fewer data units per pixel until both axes share one scale.
    const double units_per_px = std::max((f.x.hi - f.x.lo) / f.area.width, (f.y.hi - f.y.lo) / f.area.height);
    const double cx = 0.5 * (f.x.lo + f.x.hi), cy = 0.5 * (f.y.lo + f.y.hi);
    f.x = {cx - 0.5 * units_per_px * f.area.width, cx + 0.5 * units_per_px * f.area.width};
    f.y = {cy - 0.5 * units_per_px * f.area.height, cy + 0.5 * units_per_px * f.area.height};
  }
  return f;
}

void Plot2D::drawHeatmap(cv::Mat& canvas, const Frame& frame) const {
  if (!has_heatmap_) return;
  const cv::Mat& values = heatmap_.values;
  const HeatmapStyle& style = heatmap_.style;
  double vmin = style.vmin, vmax = style.vmax;
  if (!(vmax > vmin)) {
    vmin = std::numeric_limits<double>::infinity();
    vmax = -vmin;
    for (int r = 0; r < values.rows; ++r)
      for (int c = 0; c < values.cols; ++c) {
        const double v = values.at<double>(r, c);
        if (!std::isfinite(v)) continue;
        vmin = std::min(vmin, v);
        vmax = std::max(vmax, v);
      }
    if (!std::isfinite(vmin)) vmin = 0.0, vmax = 1.0;
    if (!(vmax > vmin)) vmax = vmin + 1.0;
  }
  // Colour every cell once, then fill each pixel of the axes from the cell under its centre.
  cv::Mat levels(values.size(), CV_8UC1);
  for (int r = 0; r < values.rows; ++r)
    for (int c = 0; c < values.cols; ++c) {
      const double v = values.at<double>(r, c);
      const double f = std::isfinite(v) ? std::clamp((v - vmin) / (vmax - vmin), 0.0, 1.0) : 0.0;
      levels.at<uchar>(r, c) = static_cast<uchar>(std::lround(255.0 * f));
    }
  cv::Mat colored;
  cv::applyColorMap(levels, colored, style.colormap);
  const cv::Vec3b invalid(static_cast<uchar>(style.invalid_color[0]), static_cast<uchar>(style.invalid_color[1]),
                          static_cast<uchar>(style.invalid_color[2]));
  const double cell_w = (heatmap_.x_max - heatmap_.x_min) / values.cols;
  const double cell_h = (heatmap_.y_max - heatmap_.y_min) / values.rows;
  cv::Mat area = canvas(frame.area);
  for (int v = 0; v < area.rows; ++v) {
    for (int u = 0; u < area.cols; ++u) {
      const cv::Point2d d = frame.toData(u + 0.5, v + 0.5);
      const double fc = std::floor((d.x - heatmap_.x_min) / cell_w);
      const double fr = std::floor((d.y - heatmap_.y_min) / cell_h);
      if (fc < 0 || fr < 0 || fc >= values.cols || fr >= values.rows) continue;
      const int c = static_cast<int>(fc), r = static_cast<int>(fr);
      area.at<cv::Vec3b>(v, u) = std::isfinite(values.at<double>(r, c)) ? colored.at<cv::Vec3b>(r, c) : invalid;
    }
  }
  if (!style.show_colorbar) return;
  // Colour bar: a vertical ramp right of the axes, vmax at the top.
  const cv::Rect bar(frame.area.x + frame.area.width + 14, frame.area.y, 16, frame.area.height);
  cv::Mat ramp(bar.height, 1, CV_8UC1);
  for (int v = 0; v < bar.height; ++v)
    ramp.at<uchar>(v, 0) =
        static_cast<uchar>(std::lround(255.0 * (1.0 - static_cast<double>(v) / std::max(1, bar.height - 1))));
  cv::Mat ramp_colored;
  cv::applyColorMap(ramp, ramp_colored, style.colormap);
  cv::resize(ramp_colored, canvas(bar), bar.size(), 0, 0, cv::INTER_NEAREST);
  cv::rectangle(canvas, bar, kFrameColor, 1);
  const std::vector<double> ticks = niceTicks(vmin, vmax, 5);
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : (vmax - vmin);
  int max_label_w = 0;
  for (double t : ticks) {
    const int y = bar.y + cvRound((1.0 - (t - vmin) / (vmax - vmin)) * (bar.height - 1));
    cv::line(canvas, cv::Point(bar.x + bar.width, y), cv::Point(bar.x + bar.width + 4, y), kFrameColor, 1);
    const std::string label = formatTick(t, step);
    const cv::Size size = textSize(label, kTickFontScale);
    max_label_w = std::max(max_label_w, size.width);
    putText(canvas, label, cv::Point(bar.x + bar.width + 7, y + size.height / 2), kTickFontScale);
  }
  putVerticalText(canvas, style.colorbar_label, cv::Point(bar.x + bar.width + 16 + max_label_w, bar.y + bar.height / 2),
                  kLabelFontScale);
}

void Plot2D::drawAxes(cv::Mat& canvas, const Frame& frame) const {
  const cv::Rect& a = frame.area;
  const std::vector<double> x_ticks = niceTicks(frame.x.lo, frame.x.hi, std::max(2, a.width / 110));
  const std::vector<double> y_ticks = niceTicks(frame.y.lo, frame.y.hi, std::max(2, a.height / 80));
  const double x_step = x_ticks.size() > 1 ? x_ticks[1] - x_ticks[0] : 1.0;
  const double y_step = y_ticks.size() > 1 ? y_ticks[1] - y_ticks[0] : 1.0;
  if (grid_ && !has_heatmap_) {
    for (double t : x_ticks) {
      const int u = a.x + cvRound(frame.toLocal(t, frame.y.lo).x);
      cv::line(canvas, cv::Point(u, a.y), cv::Point(u, a.y + a.height), kGridColor, 1);
    }
    for (double t : y_ticks) {
      const int v = a.y + cvRound(frame.toLocal(frame.x.lo, t).y);
      cv::line(canvas, cv::Point(a.x, v), cv::Point(a.x + a.width, v), kGridColor, 1);
    }
  }
  for (double t : x_ticks) {
    const int u = a.x + cvRound(frame.toLocal(t, frame.y.lo).x);
    cv::line(canvas, cv::Point(u, a.y + a.height), cv::Point(u, a.y + a.height + 5), kFrameColor, 1);
    const std::string label = formatTick(t, x_step);
    const cv::Size size = textSize(label, kTickFontScale);
    putText(canvas, label, cv::Point(u - size.width / 2, a.y + a.height + 9 + size.height), kTickFontScale);
  }
  for (double t : y_ticks) {
    const int v = a.y + cvRound(frame.toLocal(frame.x.lo, t).y);
    cv::line(canvas, cv::Point(a.x - 5, v), cv::Point(a.x, v), kFrameColor, 1);
    const std::string label = formatTick(t, y_step);
    const cv::Size size = textSize(label, kTickFontScale);
    putText(canvas, label, cv::Point(a.x - 8 - size.width, v + size.height / 2), kTickFontScale);
  }
  cv::rectangle(canvas, a, kFrameColor, 1);
  if (!x_label_.empty()) {
    const cv::Size size = textSize(x_label_, kLabelFontScale);
    putText(canvas, x_label_, cv::Point(a.x + (a.width - size.width) / 2, a.y + a.height + 30 + size.height),
            kLabelFontScale);
  }
  putVerticalText(canvas, y_label_, cv::Point(14, a.y + a.height / 2), kLabelFontScale);
  if (!title_.empty()) {
    const cv::Size size = textSize(title_, kTitleFontScale);
    putText(canvas, title_, cv::Point(a.x + (a.width - size.width) / 2, a.y - 14), kTitleFontScale);
  }
}

void Plot2D::drawSeries(cv::Mat& canvas, const Frame& frame) const {
  cv::Mat area = canvas(frame.area);
  // Clip a little outside the axes so thick lines end cleanly at the frame.
  const cv::Point2d lo(-20.0, -20.0), hi(frame.area.width + 20.0, frame.area.height + 20.0);
  auto segment = [&](double x0, double y0, double x1, double y1, const cv::Scalar& color, int thickness) {
    if (!finite2(x0, y0) || !finite2(x1, y1)) return;
    cv::Point2d a = frame.toLocal(x0, y0), b = frame.toLocal(x1, y1);
    if (!clipSegment(&a, &b, lo, hi)) return;
    cv::line(area, toFixed(a), toFixed(b), color, thickness, cv::LINE_AA, kShift);
  };
  for (const auto& s : series_) {
    switch (s.kind) {
      case SeriesKind::kLine:
        for (std::size_t i = 1; i < s.xs.size(); ++i)
          segment(s.xs[i - 1], s.ys[i - 1], s.xs[i], s.ys[i], s.color, s.size_px);
        if (s.xs.size() == 1 && finite2(s.xs[0], s.ys[0]))
          drawMarker(area, frame.toLocal(s.xs[0], s.ys[0]), s.size_px, MarkerShape::kCircle, s.color);
        break;
      case SeriesKind::kSegments:
        for (std::size_t i = 0; i < s.xs.size(); ++i) segment(s.xs[i], s.ys[i], s.xs1[i], s.ys1[i], s.color, s.size_px);
        break;
      case SeriesKind::kScatter:
        for (std::size_t i = 0; i < s.xs.size(); ++i) {
          if (!finite2(s.xs[i], s.ys[i])) continue;
          const cv::Point2d p = frame.toLocal(s.xs[i], s.ys[i]);
          if (p.x < lo.x || p.y < lo.y || p.x > hi.x || p.y > hi.y) continue;
          drawMarker(area, p, s.size_px, s.shape, s.color);
        }
        break;
    }
  }
}

void Plot2D::drawLegend(cv::Mat& canvas, const Frame& frame) const {
  if (legend_ == LegendLocation::kNone) return;
  std::vector<const Series*> entries;
  for (const auto& s : series_)
    if (!s.label.empty()) entries.push_back(&s);
  if (entries.empty()) return;
  constexpr int kRowH = 20, kSampleW = 28, kPad = 8;
  int text_w = 0;
  for (const Series* s : entries) text_w = std::max(text_w, textSize(s->label, kTickFontScale).width);
  const cv::Size box_size(kPad * 3 + kSampleW + text_w, kPad + kRowH * static_cast<int>(entries.size()));
  const cv::Rect& a = frame.area;
  const bool right = legend_ == LegendLocation::kTopRight || legend_ == LegendLocation::kBottomRight;
  const bool top = legend_ == LegendLocation::kTopRight || legend_ == LegendLocation::kTopLeft;
  const cv::Point origin(right ? a.x + a.width - box_size.width - 10 : a.x + 10,
                         top ? a.y + 10 : a.y + a.height - box_size.height - 10);
  const cv::Rect box(origin, box_size);
  canvas(box & cv::Rect(0, 0, canvas.cols, canvas.rows)).setTo(kWhite);
  cv::rectangle(canvas, box, cv::Scalar(160, 160, 160), 1);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const Series& s = *entries[k];
    const int cy = box.y + kPad / 2 + kRowH * static_cast<int>(k) + kRowH / 2;
    const int x0 = box.x + kPad;
    if (s.kind == SeriesKind::kScatter) {
      drawMarker(canvas, cv::Point2d(x0 + kSampleW / 2.0, cy), std::min(s.size_px, 6), s.shape, s.color);
    } else {
      cv::line(canvas, cv::Point(x0, cy), cv::Point(x0 + kSampleW, cy), s.color, std::min(s.size_px, 4), cv::LINE_AA);
    }
    const cv::Size size = textSize(s.label, kTickFontScale);
    putText(canvas, s.label, cv::Point(x0 + kSampleW + kPad, cy + size.height / 2), kTickFontScale);
  }
}

cv::Mat Plot2D::render() const {
  cv::Mat canvas(height_, width_, CV_8UC3, kWhite);
  const Frame frame = layout();
  drawHeatmap(canvas, frame);
  drawAxes(canvas, frame);
  drawSeries(canvas, frame);
  cv::rectangle(canvas, frame.area, kFrameColor, 1);  // lines may have painted over the frame
  drawLegend(canvas, frame);
  return canvas;
}

void Plot2D::savePng(const std::string& path) const {
  const cv::Mat image = render();
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write plot '" + path + "': " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot write plot '" + path + "'");
}

}  // namespace eval
}  // namespace vims
