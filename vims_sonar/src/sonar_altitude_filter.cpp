#include "vims_sonar/sonar_altitude_filter.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>

namespace vims {
namespace {
constexpr const char* kComponent = "sonar_filter";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

SonarAltitudeFilter::SonarAltitudeFilter(const SonarFilterOptions& options, const SonarCalibration& calibration,
                                         LoggerPtr logger)
    : options_(options),
      sigma_(std::max(calibration.range_noise_std, options.min_noise_std_m)),
      min_range_(calibration.min_range),
      max_range_(calibration.max_range),
      max_gap_s_(calibration.rate_hz > 0.0
                     ? std::max(options.max_gap_s, (options.acquire_samples + 1) / calibration.rate_hz)
                     : options.max_gap_s),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  options_.validate(ConfigReader::fromString("", "sonar filter options"));
  if (max_gap_s_ > options_.max_gap_s) {
    logger_->info(kComponent,
                  VIMS_STR("max_gap_s raised to " << max_gap_s_ << " s: " << options_.acquire_samples + 1
                                                  << " periods of the " << calibration.rate_hz << " Hz sonar"));
  }
}

bool SonarAltitudeFilter::validRange(double r) const { return std::isfinite(r) && r >= min_range_ && r <= max_range_; }

SonarAltitudeFilter::Line SonarAltitudeFilter::fitLine(const std::vector<Sample>& samples, int skip) {
  Line line;
  double t_sum = 0.0, r_sum = 0.0;
  for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
    if (i == skip) continue;
    t_sum += samples[i].t;
    r_sum += samples[i].r;
    ++line.n;
  }
  if (line.n == 0) return line;
  line.t_mean = t_sum / line.n;
  line.r_mean = r_sum / line.n;
  double sxy = 0.0;
  for (int i = 0; i < static_cast<int>(samples.size()); ++i) {
    if (i == skip) continue;
    const double dt = samples[i].t - line.t_mean;
    line.sxx += dt * dt;
    sxy += dt * (samples[i].r - line.r_mean);
  }
  // Stamps are strictly increasing (duplicates are dropouts), so sxx > 0 whenever n >= 2.
  line.slope = line.sxx > 1e-12 ? sxy / line.sxx : 0.0;
  return line;
}

double SonarAltitudeFilter::gate(const Line& line, double t) const {
  const double u = t - line.t_mean;
  const double n = std::max(line.n, 1);
  // Variance of the least-squares prediction at t (textbook formula for a line fit).
  const double var_pred = sigma_ * sigma_ * (1.0 / n + (line.sxx > 1e-12 ? u * u / line.sxx : 0.0));
  // A range whose second derivative is bounded by a departs from its least-squares line by at
  // most a/2 * (u^2 + mean squared time spread) over and beyond the window.
  const double bend = 0.5 * options_.max_range_accel_mps2 * (u * u + line.sxx / n);
  return options_.gate_sigma * std::sqrt(sigma_ * sigma_ + var_pred) + bend;
}

double SonarAltitudeFilter::trendMedian(const std::vector<Sample>& window, double slope, double t) const {
  std::vector<double> moved;
  moved.reserve(window.size());
  for (const Sample& s : window) moved.push_back(s.r + slope * (t - s.t));
  const std::size_t mid = moved.size() / 2;
  std::nth_element(moved.begin(), moved.begin() + mid, moved.end());
  if (moved.size() % 2 == 1) return moved[mid];
  const double upper = moved[mid];
  const double lower = *std::max_element(moved.begin(), moved.begin() + mid);
  return 0.5 * (lower + upper);
}

void SonarAltitudeFilter::reset() {
  locked_ = false;
  have_last_t_ = false;
  next_is_reset_ = false;
  window_.clear();
  pending_.clear();
}

void SonarAltitudeFilter::emit(SonarFilterResult r, bool reset_trigger, std::vector<SonarFilterResult>* results) {
  if (reset_trigger && !r.accepted) r.status = SonarStatus::kReset;
  switch (r.status) {
    case SonarStatus::kOk:
      ++stats_.accepted;
      break;
    case SonarStatus::kOutlier:
      ++stats_.outliers;
      break;
    case SonarStatus::kDropout:
      ++stats_.dropouts;
      break;
    case SonarStatus::kWarmingUp:
    case SonarStatus::kReset:
      ++stats_.warming_up;
      break;
  }
  if (results) results->push_back(r);
}

void SonarAltitudeFilter::emitFinal(std::vector<SonarFilterResult>* results) {
  while (!pending_.empty() && !pending_.front().candidate) {
    emit(pending_.front().result, pending_.front().reset_trigger, results);
    pending_.pop_front();
  }
}

void SonarAltitudeFilter::flush(std::vector<SonarFilterResult>* results) {
  for (Pending& p : pending_) p.candidate = false;  // undecided samples stay "warming up"
  emitFinal(results);
}

void SonarAltitudeFilter::startReset(double t, const std::string& why, std::vector<SonarFilterResult>* results) {
  logger_->warn(kComponent, VIMS_STR("t=" << std::fixed << t << ": " << why << "; re-acquiring the trend"));
  if (locked_) ++stats_.resets;
  locked_ = false;
  window_.clear();
  flush(results);
  next_is_reset_ = true;
}

void SonarAltitudeFilter::feed(const SonarRange& sample, std::vector<SonarFilterResult>* results) {
  ++stats_.samples;
  const double t = sample.t;
  if (!std::isfinite(t)) {
    logger_->warnThrottled(kComponent, "bad_stamp", have_last_t_ ? last_t_ : 0.0, 5.0,
                           "range with a non-finite stamp ignored (counted as a dropout)");
    SonarFilterResult r;
    r.t = t;
    r.raw = sample.range;
    r.filtered = kNaN;
    r.status = SonarStatus::kDropout;
    flush(results);  // keep the output in input order
    emit(r, false, results);
    return;
  }
  if (have_last_t_ && t < last_t_) {
    // A bag played in a loop (or a replaced clock): the old trend belongs to another time line.
    startReset(t, VIMS_STR("clock went backwards by " << (last_t_ - t) << " s"), results);
  } else if (have_last_t_ && t == last_t_) {
    logger_->warnThrottled(kComponent, "duplicate", t, 5.0, "duplicate range stamp ignored (dropout)");
    SonarFilterResult r;
    r.t = t;
    r.raw = sample.range;
    r.filtered = kNaN;
    r.status = SonarStatus::kDropout;
    if (locked_) {
      r.filtered = fitLine(window_, -1).at(t);
      r.has_estimate = true;
      emit(r, false, results);
    } else {
      pending_.push_back(Pending{r, false, false});
      emitFinal(results);
    }
    return;
  }
  have_last_t_ = true;
  last_t_ = t;

  const bool valid = validRange(sample.range);
  if (!valid) {
    logger_->warnThrottled(kComponent, "dropout", t, 10.0,
                           VIMS_STR("dropout: range " << sample.range << " outside [" << min_range_ << ", "
                                                      << max_range_ << "] or not finite"));
  }
  if (locked_ && t - window_.back().t > max_gap_s_) {
    startReset(t, VIMS_STR("no accepted range for " << (t - window_.back().t) << " s (> max_gap_s)"), results);
  }
  if (locked_) {
    feedLocked(sample, valid, results);
  } else {
    feedAcquiring(sample, valid);
    emitFinal(results);
  }
}

void SonarAltitudeFilter::feedLocked(const SonarRange& sample, bool valid, std::vector<SonarFilterResult>* results) {
  const Line line = fitLine(window_, -1);
  SonarFilterResult r;
  r.t = sample.t;
  r.raw = sample.range;
  r.has_estimate = true;
  r.filtered = line.at(sample.t);
  if (!valid) {
    r.status = SonarStatus::kDropout;
    emit(r, false, results);
    return;
  }
  if (std::abs(sample.range - line.at(sample.t)) > gate(line, sample.t)) {
    // Too long: multipath; too short: something between the sonar and the seabed (a fish, a rock
    // taller than the gate). Either way the seabed's trend is kept.
    logger_->warnThrottled(
        kComponent, "outlier", sample.t, 10.0,
        VIMS_STR("range " << std::fixed << std::setprecision(2) << sample.range
                          << " m rejected as an outlier, the seabed's trend is at " << line.at(sample.t) << " m ("
                          << (sample.range < line.at(sample.t) ? "a fish or a rock under the beam?" : "multipath?")
                          << "); further outliers within 10 s are counted, not logged"));
    r.status = SonarStatus::kOutlier;
    emit(r, false, results);
    return;
  }
  window_.push_back({sample.t, sample.range});
  if (static_cast<int>(window_.size()) > options_.window_size) window_.erase(window_.begin());
  r.filtered = trendMedian(window_, fitLine(window_, -1).slope, sample.t);
  r.accepted = true;
  r.status = SonarStatus::kOk;
  emit(r, false, results);
}

void SonarAltitudeFilter::feedAcquiring(const SonarRange& sample, bool valid) {
  Pending p;
  p.result.t = sample.t;
  p.result.raw = sample.range;
  p.result.filtered = kNaN;
  p.result.status = valid ? SonarStatus::kWarmingUp : SonarStatus::kDropout;
  p.candidate = valid;
  p.reset_trigger = next_is_reset_;
  next_is_reset_ = false;
  pending_.push_back(p);
  // Candidates older than max_gap_s can no longer share a straight line with new samples.
  for (Pending& q : pending_) {
    if (q.candidate && sample.t - q.result.t > max_gap_s_) q.candidate = false;
  }
  if (valid) tryAcquire();
}

void SonarAltitudeFilter::tryAcquire() {
  std::vector<int> index;  // positions in pending_ of the newest acquire_samples candidates
  for (int i = static_cast<int>(pending_.size()) - 1;
       i >= 0 && static_cast<int>(index.size()) < options_.acquire_samples; --i) {
    if (pending_[i].candidate) index.push_back(i);
  }
  if (static_cast<int>(index.size()) < options_.acquire_samples) return;
  std::reverse(index.begin(), index.end());
  std::vector<Sample> set;
  for (int i : index) set.push_back({pending_[i].result.t, pending_[i].result.raw});

  // Leave-one-out: each sample against the line through the others.
  int worst = -1;
  double worst_score = 0.0;
  for (int j = 0; j < static_cast<int>(set.size()); ++j) {
    const Line others = fitLine(set, j);
    const double score = std::abs(set[j].r - others.at(set[j].t)) / gate(others, set[j].t);
    if (score > worst_score) {
      worst_score = score;
      worst = j;
    }
  }
  if (worst_score > 1.0) {
    Pending& bad = pending_[index[worst]];
    bad.candidate = false;
    bad.result.status = SonarStatus::kOutlier;
    return;
  }

  // Consistent: lock on these samples. Older candidates left over from failed attempts are
  // judged against the new trend like any sample of the locked filter.
  const Line line = fitLine(set, -1);
  window_.clear();
  for (Pending& q : pending_) {
    if (!q.candidate) continue;
    const bool in_set = std::any_of(set.begin(), set.end(), [&](const Sample& s) { return s.t == q.result.t; });
    if (in_set || std::abs(q.result.raw - line.at(q.result.t)) <= gate(line, q.result.t)) {
      window_.push_back({q.result.t, q.result.raw});
      q.result.accepted = true;
      q.result.status = SonarStatus::kOk;
    } else {
      q.result.status = SonarStatus::kOutlier;
    }
  }
  const double slope = fitLine(window_, -1).slope;
  for (Pending& q : pending_) {
    if (!q.candidate) continue;
    q.result.has_estimate = true;
    q.result.filtered = q.result.accepted ? trendMedian(window_, slope, q.result.t) : line.at(q.result.t);
    q.candidate = false;
  }
  while (static_cast<int>(window_.size()) > options_.window_size) window_.erase(window_.begin());
  locked_ = true;
  logger_->info(kComponent, VIMS_STR("t=" << std::fixed << set.back().t << ": trend acquired at "
                                          << line.at(set.back().t) << " m"));
}

}  // namespace vims
