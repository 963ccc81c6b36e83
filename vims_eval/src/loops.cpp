#include "vims_eval/loops.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "vims_common/timing.h"
#include "vims_eval/association.h"
#include "vims_eval/metrics.h"

namespace vims {
namespace eval {
namespace {

const std::array<const char*, 14> kColumns = {"t_query", "t_match",      "accepted",  "x",    "y",
                                              "z",       "qx",           "qy",        "qz",   "qw",
                                              "inliers", "mag_distance", "bow_score", "stage"};

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\r\n");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream is(line);
  while (std::getline(is, field, ',')) fields.push_back(trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();  // getline drops a trailing empty field
  return fields;
}

class RowParser {
 public:
  RowParser(const std::string& source, int line) : source_(source), line_(line) {}

  [[noreturn]] void fail(const std::string& message) const {
    throw std::runtime_error(source_ + ":" + std::to_string(line_) + ": " + message);
  }

  double number(const std::string& text, const char* column) const {
    const std::optional<double> v = parseDouble(text);
    if (!v) fail(std::string("column '") + column + "': '" + text + "' is not a number");
    return *v;
  }

  double finiteNumber(const std::string& text, const char* column) const {
    const double v = number(text, column);
    if (!std::isfinite(v)) fail(std::string("column '") + column + "': value must be finite");
    return v;
  }

  /// Empty or "nan" mean "not available" for the diagnostic columns.
  double optionalNumber(const std::string& text, const char* column) const {
    if (text.empty()) return std::nan("");
    return number(text, column);
  }

  bool boolean(const std::string& text, const char* column) const {
    if (text == "1" || text == "true" || text == "True" || text == "TRUE") return true;
    if (text == "0" || text == "false" || text == "False" || text == "FALSE") return false;
    fail(std::string("column '") + column + "': '" + text + "' is not 0/1/true/false");
  }

  int integer(const std::string& text, const char* column) const {
    if (text.empty()) return -1;
    const double v = number(text, column);
    if (!std::isfinite(v) || v != std::floor(v) || std::abs(v) > 2e9)
      fail(std::string("column '") + column + "': '" + text + "' is not an integer");
    return static_cast<int>(v);
  }

 private:
  static std::optional<double> parseDouble(const std::string& text) {
    if (text.empty()) return std::nullopt;
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size() || errno == ERANGE) return std::nullopt;
    return v;
  }

  const std::string& source_;
  int line_;
};

}  // namespace

std::vector<LoopRecord> parseLoopCsv(std::istream& in, const std::string& source_name) {
  std::vector<LoopRecord> records;
  std::map<std::string, std::size_t> column_index;
  std::size_t header_size = 0;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string stripped = trim(line);
    if (stripped.empty() || stripped[0] == '#') continue;
    const std::vector<std::string> fields = splitFields(stripped);
    RowParser row(source_name, line_no);
    if (header_size == 0) {
      for (std::size_t i = 0; i < fields.size(); ++i) column_index[fields[i]] = i;
      for (const char* name : kColumns)
        if (!column_index.count(name)) row.fail(std::string("header lacks column '") + name + "'");
      header_size = fields.size();
      continue;
    }
    if (fields.size() != header_size)
      row.fail("expected " + std::to_string(header_size) + " fields, got " + std::to_string(fields.size()));
    auto field = [&](const char* name) -> const std::string& { return fields[column_index.at(name)]; };

    LoopRecord r;
    r.line = line_no;
    r.t_query = row.finiteNumber(field("t_query"), "t_query");
    r.t_match = row.finiteNumber(field("t_match"), "t_match");
    r.accepted = row.boolean(field("accepted"), "accepted");
    const Eigen::Vector3d p_m_q(row.finiteNumber(field("x"), "x"), row.finiteNumber(field("y"), "y"),
                                row.finiteNumber(field("z"), "z"));
    Eigen::Quaterniond q_m_q(row.finiteNumber(field("qw"), "qw"), row.finiteNumber(field("qx"), "qx"),
                             row.finiteNumber(field("qy"), "qy"), row.finiteNumber(field("qz"), "qz"));
    if (q_m_q.norm() < 1e-6) row.fail("zero quaternion");
    q_m_q.normalize();
    r.T_match_query = Eigen::Isometry3d::Identity();
    r.T_match_query.linear() = q_m_q.toRotationMatrix();
    r.T_match_query.translation() = p_m_q;
    r.inliers = row.integer(field("inliers"), "inliers");
    r.mag_distance = row.optionalNumber(field("mag_distance"), "mag_distance");
    r.bow_score = row.optionalNumber(field("bow_score"), "bow_score");
    r.stage = field("stage");
    if (column_index.count("match_in_map")) r.match_in_map = row.boolean(field("match_in_map"), "match_in_map");
    records.push_back(r);
  }
  if (header_size == 0)
    throw std::runtime_error(source_name + ": no header row (expected columns t_query,t_match,accepted,...)");
  return records;
}

std::vector<LoopRecord> readLoopCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open loop log '" + path + "'");
  return parseLoopCsv(in, path);
}

LoopAccuracy loopAccuracy(const LoopScore& score) {
  std::vector<double> trans, rot;
  for (const ScoredLoop& l : score.loops) {
    if (!l.record.accepted || !l.has_gt) continue;
    trans.push_back(l.trans_error_m);
    rot.push_back(l.rot_error_deg);
  }
  LoopAccuracy a;
  a.loops = trans.size();
  a.trans_error_median_m = percentile(trans, 0.5);
  a.trans_error_p90_m = percentile(trans, 0.9);
  a.rot_error_median_deg = percentile(rot, 0.5);
  return a;
}

double LoopScore::precision() const {
  const std::size_t scored = correct + wrong;
  return scored == 0 ? 1.0 : static_cast<double>(correct) / static_cast<double>(scored);
}

LoopScore scoreLoops(const std::vector<LoopRecord>& records, const std::vector<StampedPose>& gt,
                     const LoopScoringOptions& options, const std::vector<StampedPose>* map_gt) {
  LoopScore score;
  score.verifications = records.size();
  for (const auto& record : records) {
    ScoredLoop s;
    s.record = record;
    const std::optional<StampedPose> T_w_query = interpolatePose(gt, record.t_query, options.max_gt_gap_s);
    const std::vector<StampedPose>* match_gt = record.match_in_map ? map_gt : &gt;
    const std::optional<StampedPose> T_w_match =
        match_gt ? interpolatePose(*match_gt, record.t_match, options.max_gt_gap_s) : std::nullopt;
    if (T_w_query && T_w_match) {
      s.has_gt = true;
      s.p_w_query_gt = T_w_query->p;
      s.p_w_match_gt = T_w_match->p;
      // T_match_query = T_w_match^-1 T_w_query.
      const Eigen::Quaterniond q_m_q_gt = T_w_match->q.conjugate() * T_w_query->q;
      s.T_match_query_gt = Eigen::Isometry3d::Identity();
      s.T_match_query_gt.linear() = q_m_q_gt.toRotationMatrix();
      s.T_match_query_gt.translation() = T_w_match->q.conjugate() * (T_w_query->p - T_w_match->p);
      s.trans_error_m = (record.T_match_query.translation() - s.T_match_query_gt.translation()).norm();
      const Eigen::Quaterniond q_m_q_est(record.T_match_query.linear());
      s.rot_error_deg = rotationAngleDeg(q_m_q_gt.conjugate() * q_m_q_est);
      s.within_tolerance = s.trans_error_m <= options.trans_tol_m && s.rot_error_deg <= options.rot_tol_deg;
    }
    if (record.accepted) {
      ++score.accepted;
      if (!s.has_gt)
        ++score.accepted_no_gt;
      else if (s.within_tolerance)
        ++score.correct;
      else
        ++score.wrong;
    } else if (s.has_gt && s.within_tolerance) {
      ++score.rejected_correct;
    }
    score.loops.push_back(s);
  }
  return score;
}

}  // namespace eval
}  // namespace vims
