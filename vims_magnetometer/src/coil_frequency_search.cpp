#include "vims_magnetometer/coil_frequency_search.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <opencv2/core.hpp>

namespace vims {
namespace {

/// Hann-weighted DTFT power summed over the three axes at `f`, with the samples' own stamps.
double dtftPower(const std::vector<MagSample>& samples, const Eigen::Vector3d& mean, double f) {
  const std::size_t n = samples.size();
  const double t0 = samples.front().t;
  std::complex<double> X[3] = {0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < n; ++i) {
    const double w = 0.5 - 0.5 * std::cos(2.0 * M_PI * static_cast<double>(i) / static_cast<double>(n));
    const std::complex<double> e = std::polar(w, -2.0 * M_PI * f * (samples[i].t - t0));
    for (int a = 0; a < 3; ++a) X[a] += (samples[i].field[a] - mean[a]) * e;
  }
  return std::norm(X[0]) + std::norm(X[1]) + std::norm(X[2]);
}

}  // namespace

CoilLine findCoilLine(const std::vector<MagSample>& samples, double rate_hz, const CoilSearchOptions& options) {
  CoilLine line;
  const int n = static_cast<int>(samples.size());
  if (n < 64 || !(rate_hz > 0.0)) return line;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const MagSample& s : samples) mean += s.field;
  mean /= n;

  const int n_fft = cv::getOptimalDFTSize(2 * n);
  std::vector<double> power(n_fft / 2 + 1, 0.0);
  cv::Mat signal(1, n_fft, CV_64F);
  cv::Mat spectrum;
  for (int a = 0; a < 3; ++a) {
    signal.setTo(0.0);
    double* x = signal.ptr<double>(0);
    for (int i = 0; i < n; ++i) {
      const double w = 0.5 - 0.5 * std::cos(2.0 * M_PI * i / n);
      x[i] = w * (samples[i].field[a] - mean[a]);
    }
    cv::dft(signal, spectrum, cv::DFT_COMPLEX_OUTPUT);
    const cv::Vec2d* X = spectrum.ptr<cv::Vec2d>(0);
    for (std::size_t k = 0; k < power.size(); ++k) power[k] += X[k][0] * X[k][0] + X[k][1] * X[k][1];
  }

  const double bin_hz = rate_hz / n_fft;
  const int k_lo = std::max(1, static_cast<int>(std::ceil(options.min_frequency_hz / bin_hz)));
  const int k_hi = std::min(static_cast<int>(power.size()) - 2,
                            static_cast<int>(std::floor(options.max_fraction_of_nyquist * 0.5 * rate_hz / bin_hz)));
  if (k_hi - k_lo < 8) return line;
  // The coil is a narrow line: a local maximum far above the spectrum around it. Comparing with
  // the local median (1 Hz each side, the main lobe left out) rather than the band's keeps the
  // slow geomagnetic part's leakage near the band's low edge, a smooth slope, from looking like
  // a line.
  const int half_window = std::max(8, static_cast<int>(std::lround(1.0 / bin_hz)));
  const int lobe = 4;  // the Hann main lobe spans +-2 bins of the unpadded transform
  int k_peak = -1;
  std::vector<double> around;
  for (int k = k_lo + 1; k < k_hi; ++k) {
    if (power[k] < power[k - 1] || power[k] < power[k + 1]) continue;
    around.clear();
    for (int j = std::max(1, k - half_window); j <= std::min(static_cast<int>(power.size()) - 1, k + half_window); ++j)
      if (std::abs(j - k) > lobe) around.push_back(power[j]);
    std::nth_element(around.begin(), around.begin() + around.size() / 2, around.end());
    const double median = around[around.size() / 2];
    const double ratio = median > 0.0 ? power[k] / median : 0.0;
    if (ratio > line.peak_to_median) {
      line.peak_to_median = ratio;
      k_peak = k;
    }
  }
  if (k_peak < 0) return line;
  line.frequency_hz = k_peak * bin_hz;
  line.found = line.peak_to_median >= options.min_peak_to_median;
  if (!line.found) return line;

  // Golden-section search of the DTFT power within one zero-padded bin each side of the peak:
  // the Hann main lobe is four such bins wide, so the power is unimodal there.
  const double phi = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = (k_peak - 1) * bin_hz;
  double b = (k_peak + 1) * bin_hz;
  double c = b - phi * (b - a);
  double d = a + phi * (b - a);
  double pc = dtftPower(samples, mean, c);
  double pd = dtftPower(samples, mean, d);
  while (b - a > 1e-5) {
    if (pc > pd) {
      b = d;
      d = c;
      pd = pc;
      c = b - phi * (b - a);
      pc = dtftPower(samples, mean, c);
    } else {
      a = c;
      c = d;
      pc = pd;
      d = a + phi * (b - a);
      pd = dtftPower(samples, mean, d);
    }
  }
  line.frequency_hz = 0.5 * (a + b);
  return line;
}

}  // namespace vims
