#include "vims_eval/place_recognition.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "vims_common/config_reader.h"
#include "vims_common/magnetic_signature.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_eval/ablation.h"
#include "vims_eval/association.h"
#include "vims_eval/cli.h"
#include "vims_eval/map_figures.h"
#include "vims_eval/plot.h"
#include "vims_eval/report.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/pose_graph_manager.h"

namespace fs = std::filesystem;

namespace vims {
namespace eval {
namespace {

constexpr float kNever = -std::numeric_limits<float>::infinity();

std::string fixed(double v, int decimals) { return formatFixed(v, decimals); }

std::string precise(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.8g", v);
  return buf;
}

/// A valid magnetic signature window of mag_signatures.csv.
struct Signature {
  double t = 0.0;
  Eigen::Vector3d enu = Eigen::Vector3d::Zero();
};

/// Reads the valid rows of mag_signatures.csv (header t,E,N,U,snr,valid,coil,invalid_reason;
/// column order taken from the header) of the first coil (this study compares one coil's
/// signatures; a file without the coil column has one coil), sorted by time.
std::vector<Signature> readValidSignatures(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error("'" + path + "' is empty");
  auto split = [](const std::string& text) {
    std::vector<std::string> fields;
    std::stringstream ss(text);
    std::string f;
    while (std::getline(ss, f, ',')) fields.push_back(f);
    if (!text.empty() && text.back() == ',') fields.emplace_back();
    return fields;
  };
  const auto header = split(line);
  std::map<std::string, std::size_t> column;
  for (std::size_t i = 0; i < header.size(); ++i) column[header[i]] = i;
  for (const char* key : {"t", "E", "N", "U", "valid"})
    if (!column.count(key)) throw std::runtime_error("'" + path + "': header has no column '" + key + "'");
  std::vector<Signature> out;
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    const auto f = split(line);
    try {
      if (f.size() < header.size() - 1) throw std::invalid_argument("too few fields");
      if (std::stoi(f.at(column["valid"])) != 1) continue;
      if (column.count("coil") && std::stoi(f.at(column["coil"])) != 0) continue;
      Signature s;
      s.t = std::stod(f.at(column["t"]));
      s.enu = {std::stod(f.at(column["E"])), std::stod(f.at(column["N"])), std::stod(f.at(column["U"]))};
      if (std::isfinite(s.t) && s.enu.allFinite()) out.push_back(s);
    } catch (const std::exception& e) {
      throw std::runtime_error("'" + path + "':" + std::to_string(line_number) + ": " + e.what());
    }
  }
  std::sort(out.begin(), out.end(), [](const Signature& a, const Signature& b) { return a.t < b.t; });
  return out;
}

/// The valid signature nearest in time within max_dt (the detector's query signature rule).
std::optional<Eigen::Vector3d> nearestSignature(const std::vector<Signature>& sigs, double t, double max_dt) {
  const auto it = std::lower_bound(sigs.begin(), sigs.end(), t, [](const Signature& s, double v) { return s.t < v; });
  std::optional<Eigen::Vector3d> best;
  double best_dt = max_dt;
  for (auto c : {it, it == sigs.begin() ? sigs.end() : std::prev(it)}) {
    if (c == sigs.end()) continue;
    const double dt = std::abs(c->t - t);
    if (dt <= best_dt) best_dt = dt, best = c->enu;
  }
  return best;
}

cv::Scalar outcomeColor(PairOutcome o) {
  switch (o) {
    case PairOutcome::kTruePositive:
      return {44, 160, 44};  // green
    case PairOutcome::kFalsePositive:
      return {40, 39, 214};  // red
    case PairOutcome::kFalseNegative:
      return {14, 127, 255};  // orange
    case PairOutcome::kTrueNegative:
      return {215, 215, 215};  // light grey
    case PairOutcome::kExcluded:
      break;
  }
  return {255, 255, 255};
}

/// Display priority when a block of cells becomes one pixel.
int outcomePriority(uint8_t o) {
  switch (static_cast<PairOutcome>(o)) {
    case PairOutcome::kTruePositive:
      return 4;
    case PairOutcome::kFalsePositive:
      return 3;
    case PairOutcome::kFalseNegative:
      return 2;
    case PairOutcome::kTrueNegative:
      return 1;
    case PairOutcome::kExcluded:
      break;
  }
  return 0;
}

}  // namespace

double fBeta(double precision, double recall, double beta) {
  const double b2 = beta * beta;
  const double den = b2 * precision + recall;
  return den > 0.0 ? (1.0 + b2) * precision * recall / den : 0.0;
}

PrCurve computePrCurve(const std::string& method, const std::vector<float>& scores, const std::vector<uint8_t>& truth) {
  if (scores.size() != truth.size()) throw std::invalid_argument("computePrCurve: scores and truth differ in length");
  PrCurve curve;
  curve.method = method;
  curve.pairs = scores.size();
  for (uint8_t t : truth) curve.positives += t ? 1 : 0;
  curve.best.threshold = std::numeric_limits<double>::infinity();
  std::vector<uint32_t> order;
  order.reserve(scores.size());
  for (uint32_t i = 0; i < scores.size(); ++i)
    if (std::isfinite(scores[i])) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return scores[a] > scores[b]; });
  std::size_t tp = 0, fp = 0;
  // The curve is kept at a resolution of 0.001 in precision or recall (a few thousand points
  // instead of one per distinct score); the best F0.5 is searched over every threshold.
  constexpr double kResolution = 1e-3;
  for (std::size_t k = 0; k < order.size(); ++k) {
    (truth[order[k]] ? tp : fp) += 1;
    const bool boundary = k + 1 == order.size() || scores[order[k + 1]] < scores[order[k]];
    if (!boundary) continue;
    PrPoint p;
    p.threshold = scores[order[k]];
    p.tp = tp;
    p.fp = fp;
    p.precision = static_cast<double>(tp) / static_cast<double>(tp + fp);
    p.recall = curve.positives > 0 ? static_cast<double>(tp) / static_cast<double>(curve.positives) : 0.0;
    const double f = fBeta(p.precision, p.recall, 0.5);
    if (f > curve.best_f05) curve.best_f05 = f, curve.best = p;
    if (curve.points.empty() || k + 1 == order.size() ||
        std::abs(p.recall - curve.points.back().recall) >= kResolution ||
        std::abs(p.precision - curve.points.back().precision) >= kResolution)
      curve.points.push_back(p);
  }
  return curve;
}

cv::Mat outcomeMatrix(std::size_t num_keyframes, const std::vector<std::pair<uint32_t, uint32_t>>& pairs,
                      const std::vector<float>& scores, const std::vector<uint8_t>& truth, double threshold) {
  if (scores.size() != pairs.size() || truth.size() != pairs.size())
    throw std::invalid_argument("outcomeMatrix: pairs, scores and truth differ in length");
  const int n = static_cast<int>(num_keyframes);
  cv::Mat m(n, n, CV_8UC1, cv::Scalar(static_cast<int>(PairOutcome::kExcluded)));
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto [x, y] = pairs[i];
    if (x >= num_keyframes || y >= num_keyframes) throw std::out_of_range("outcomeMatrix: keyframe index out of range");
    const bool recognised = std::isfinite(scores[i]) && scores[i] >= threshold;
    PairOutcome o = truth[i] ? (recognised ? PairOutcome::kTruePositive : PairOutcome::kFalseNegative)
                             : (recognised ? PairOutcome::kFalsePositive : PairOutcome::kTrueNegative);
    m.at<uint8_t>(static_cast<int>(y), static_cast<int>(x)) = static_cast<uint8_t>(o);
  }
  return m;
}

void writeOutcomeMatrixPng(const cv::Mat& outcomes, const std::string& title, const std::string& png_path) {
  if (outcomes.empty() || outcomes.type() != CV_8UC1 || outcomes.rows != outcomes.cols)
    throw std::invalid_argument("writeOutcomeMatrixPng: expects a square CV_8UC1 matrix");
  const int n = outcomes.rows;
  constexpr int kMaxCells = 800;
  const int block = (n + kMaxCells - 1) / kMaxCells;
  const int cells = (n + block - 1) / block;
  cv::Mat reduced(cells, cells, CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      uint8_t& dst = reduced.at<uint8_t>(r / block, c / block);
      const uint8_t v = outcomes.at<uint8_t>(r, c);
      if (outcomePriority(v) > outcomePriority(dst)) dst = v;
    }
  const int side = 800;
  const int left = 90, top = 50, right = 190, bottom = 70;
  cv::Mat canvas(top + side + bottom, left + side + right, CV_8UC3, cv::Scalar(255, 255, 255));
  const double px_per_cell = static_cast<double>(side) / cells;
  for (int r = 0; r < cells; ++r)
    for (int c = 0; c < cells; ++c) {
      const uint8_t v = reduced.at<uint8_t>(r, c);
      if (v == static_cast<uint8_t>(PairOutcome::kExcluded)) continue;
      // Row r (historical index) grows upwards: origin at the bottom left.
      const int x0 = left + static_cast<int>(std::floor(c * px_per_cell));
      const int x1 = left + static_cast<int>(std::floor((c + 1) * px_per_cell));
      const int y1 = top + side - static_cast<int>(std::floor(r * px_per_cell));
      const int y0 = top + side - static_cast<int>(std::floor((r + 1) * px_per_cell));
      cv::rectangle(canvas, cv::Point(x0, y0), cv::Point(std::max(x0, x1 - 1), std::max(y0, y1 - 1)),
                    outcomeColor(static_cast<PairOutcome>(v)), cv::FILLED);
    }
  const cv::Scalar ink(40, 40, 40);
  cv::rectangle(canvas, cv::Point(left, top), cv::Point(left + side, top + side), ink, 1);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  for (double tick : niceTicks(0.0, n, 6)) {
    if (tick < 0 || tick > n) continue;
    const int px = left + static_cast<int>(std::lround(tick / n * side));
    const int py = top + side - static_cast<int>(std::lround(tick / n * side));
    const std::string label = fixed(tick, 0);
    cv::line(canvas, cv::Point(px, top + side), cv::Point(px, top + side + 6), ink, 1);
    cv::putText(canvas, label, cv::Point(px - 4 * static_cast<int>(label.size()), top + side + 22), font, 0.45, ink, 1,
                cv::LINE_AA);
    cv::line(canvas, cv::Point(left - 6, py), cv::Point(left, py), ink, 1);
    cv::putText(canvas, label, cv::Point(left - 12 - 8 * static_cast<int>(label.size()), py + 5), font, 0.45, ink, 1,
                cv::LINE_AA);
  }
  cv::putText(canvas, "query keyframe (visual submap) x", cv::Point(left + side / 2 - 140, top + side + 52), font, 0.55,
              ink, 1, cv::LINE_AA);
  putVerticalText(canvas, "historical keyframe (visual submap) y", cv::Point(18, top + side / 2), 0.55);
  cv::putText(canvas, title, cv::Point(left, top - 18), font, 0.6, ink, 1, cv::LINE_AA);
  const std::pair<PairOutcome, const char*> legend[] = {{PairOutcome::kTruePositive, "true positive"},
                                                        {PairOutcome::kFalsePositive, "false positive"},
                                                        {PairOutcome::kFalseNegative, "false negative"},
                                                        {PairOutcome::kTrueNegative, "true negative"}};
  int ly = top + 20;
  for (const auto& [o, text] : legend) {
    cv::rectangle(canvas, cv::Point(left + side + 20, ly - 12), cv::Point(left + side + 36, ly + 2), outcomeColor(o),
                  cv::FILLED);
    cv::putText(canvas, text, cv::Point(left + side + 44, ly), font, 0.5, ink, 1, cv::LINE_AA);
    ly += 26;
  }
  cv::putText(canvas, "white: x < y + 50", cv::Point(left + side + 20, ly + 10), font, 0.45, ink, 1, cv::LINE_AA);
  if (block > 1)
    cv::putText(canvas, "1 px = " + std::to_string(block) + "x" + std::to_string(block),
                cv::Point(left + side + 20, ly + 34), font, 0.45, ink, 1, cv::LINE_AA);
  const fs::path parent = fs::path(png_path).parent_path();
  if (!parent.empty()) fs::create_directories(parent);
  if (!cv::imwrite(png_path, canvas)) throw std::runtime_error("cannot write '" + png_path + "'");
}

PlaceRecognitionOptions placeRecognitionOptionsFromConfig(const std::string& system_config_path) {
  // The system configuration vims_offline was run with (its pose_graph section).
  const PoseGraphManagerOptions pg =
      PoseGraphManagerOptions::fromReader(ConfigReader::fromFile(system_config_path).childOrEmpty("pose_graph"));
  PlaceRecognitionOptions o;
  o.loop = pg.loop;
  o.magnetic = pg.magnetic;
  return o;
}

PlaceRecognitionResult runPlaceRecognition(const PlaceRecognitionInputs& inputs, const PlaceRecognitionOptions& options,
                                           const std::string& out_dir, std::ostream& out) {
  const SequencePaths seq = SequencePaths::resolve(inputs.sequence_dir);
  if (seq.gt.empty()) throw std::runtime_error("sequence '" + inputs.sequence_dir + "' has no ground truth");
  const auto gt = readTumFile(seq.gt);
  const LoadedMap orb = loadSavedMap(inputs.orb_map, "orb", inputs.package_root);
  const LoadedMap brief = loadSavedMap(inputs.brief_map, "brief", inputs.package_root);
  const auto signatures = readValidSignatures(inputs.signatures_csv);
  const MultiScaleMap& map = *orb.map;
  const std::size_t n = map.numNodes();
  if (n == 0) throw std::runtime_error("map '" + inputs.orb_map + "' has no keyframe");

  // Per keyframe of the ORB run: GT position, signature, BoW vectors of both descriptor types.
  std::vector<double> t(n);
  std::vector<std::optional<Eigen::Vector2d>> p_gt(n);
  std::vector<std::optional<Eigen::Vector3d>> sig(n);
  std::vector<const BowVector*> bow_brief(n, nullptr);
  std::map<double, PoseGraphNodeId> brief_by_time;
  for (PoseGraphNodeId i = 0; i < brief.map->numNodes(); ++i) brief_by_time[brief.map->node(i).pose.t] = i;
  PlaceRecognitionResult result;
  result.keyframes = n;
  std::size_t brief_matched = 0;
  for (PoseGraphNodeId i = 0; i < n; ++i) {
    t[i] = map.node(i).pose.t;
    if (const auto g = interpolatePose(gt, t[i], options.max_gt_gap_s)) p_gt[i] = g->p.head<2>();
    sig[i] = nearestSignature(signatures, t[i], options.loop.query_signature_max_dt_s);
    if (sig[i]) ++result.queries_with_signature;
    // Both runs share the VIO (only the loop closer differs), so keyframe times coincide.
    auto it = brief_by_time.lower_bound(t[i] - 1e-3);
    if (it != brief_by_time.end() && std::abs(it->first - t[i]) <= 1e-3) {
      bow_brief[i] = &brief.map->node(it->second).bow;
      ++brief_matched;
    }
  }

  auto historical = [&](PoseGraphNodeId x, PoseGraphNodeId y) {
    return y < x && x - y >= static_cast<PoseGraphNodeId>(options.loop.exclude_recent_keyframes) &&
           t[x] - t[y] >= options.loop.exclude_recent_s;
  };
  // Magnetic submaps: which keyframes each clusters (the library's rule), computed once. Culled
  // keyframes (redundant submaps, docs/pose_graph.md) are not loop candidates of the running
  // system but keep their BoW vector; every method scores every keyframe pair, so they are
  // clustered here too.
  const auto& submaps = map.magneticSubmaps();
  std::vector<std::vector<PoseGraphNodeId>> clustered(submaps.size());
  for (std::size_t s = 0; s < submaps.size(); ++s)
    clustered[s] =
        map.clusteredNodes(submaps[s], options.magnetic.cluster_margin_m, MultiScaleMap::ClusterMembers::kBowVectors);

  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  std::vector<uint8_t> truth;
  std::vector<float> s_magorb, s_mag, s_orb, s_brief;
  std::vector<uint8_t> in_pool(n, 0);
  for (PoseGraphNodeId x = 0; x < n; ++x) {
    if (!p_gt[x]) continue;
    // The hierarchical detector's magnetic stage for query x (loop_detector.cpp, detect()):
    // submaps within mag_distance_relative * |s_i| + floor, the nearest mag_max_candidates,
    // their clustered keyframes, plus keyframes without magnetic coverage; without a query
    // signature the stage is skipped (every historical keyframe is in the pool).
    std::fill(in_pool.begin(), in_pool.end(), 0);
    if (sig[x]) {
      const std::vector<MagneticStageMatch> passed = magneticStageMatches(
          {{0, *sig[x]}}, submaps, options.loop, [&](const MagneticSubmap& s) { return historical(x, s.tied_node); });
      for (const MagneticStageMatch& m : passed)
        for (PoseGraphNodeId y : clustered[m.submap]) in_pool[y] = 1;
      for (PoseGraphNodeId y = 0; y < n; ++y)
        if (!map.node(y).magnetic_coverage) in_pool[y] = 1;
    } else {
      std::fill(in_pool.begin(), in_pool.end(), 1);
    }
    const BowVector& orb_x = map.node(x).bow;
    for (PoseGraphNodeId y = 0; y < x; ++y) {
      if (!p_gt[y] || !historical(x, y)) continue;
      pairs.emplace_back(x, y);
      truth.push_back((*p_gt[x] - *p_gt[y]).norm() < options.true_match_radius_m ? 1 : 0);
      const float orb_score = static_cast<float>(bowScoreL1(orb_x, map.node(y).bow));
      s_orb.push_back(orb_score);
      s_magorb.push_back(in_pool[y] && !map.node(y).bow.empty() ? orb_score : kNever);
      s_brief.push_back(bow_brief[x] && bow_brief[y] ? static_cast<float>(bowScoreL1(*bow_brief[x], *bow_brief[y]))
                                                     : 0.0f);
      if (sig[x] && sig[y] && sig[y]->norm() > 0.0)
        s_mag.push_back(static_cast<float>(-(*sig[x] - *sig[y]).norm() / sig[y]->norm()));
      else
        s_mag.push_back(kNever);
    }
  }
  if (pairs.empty()) throw std::runtime_error("no (query, historical) keyframe pair with ground truth");

  const std::vector<std::pair<std::string, const std::vector<float>*>> methods = {
      {"Mag-ORB", &s_magorb}, {"Mag", &s_mag}, {"ORB", &s_orb}, {"BRIEF", &s_brief}};
  fs::create_directories(out_dir);
  Plot2D plot(1000, 800);
  plot.setTitle("Place recognition, " + seq.name + ": " + std::to_string(pairs.size()) + " pairs, true = GT within " +
                fixed(options.true_match_radius_m, 1) + " m")
      .setAxisLabels("recall", "precision")
      .setXRange(0.0, 1.0)
      .setYRange(0.0, 1.02);
  const std::string curves_csv = (fs::path(out_dir) / "pr_curves.csv").string();
  const std::string best_csv = (fs::path(out_dir) / "pr_best_f05.csv").string();
  std::ofstream curves_out(curves_csv), best_out(best_csv);
  curves_out << "method,threshold,precision,recall,tp,fp\n";
  best_out << "method,best_f05,threshold,precision,recall,tp,fp,positives,pairs\n";
  out << "== place recognition (" << seq.name << "): " << n << " keyframes (" << result.queries_with_signature
      << " with a magnetic signature, " << brief_matched << " matched in the BRIEF run), " << pairs.size()
      << " (query, historical) pairs, " << std::count(truth.begin(), truth.end(), 1) << " true (GT within "
      << fixed(options.true_match_radius_m, 2) << " m)\n";
  char buf[256];
  std::snprintf(buf, sizeof(buf), "   %-8s %8s %10s %10s %8s %8s %8s\n", "method", "best F0.5", "precision", "recall",
                "TP", "FP", "threshold");
  out << buf;
  for (std::size_t k = 0; k < methods.size(); ++k) {
    const auto& [name, scores] = methods[k];
    PrCurve curve = computePrCurve(name, *scores, truth);
    std::vector<double> rx, py;
    for (const auto& p : curve.points) {
      rx.push_back(p.recall);
      py.push_back(p.precision);
      curves_out << name << "," << precise(p.threshold) << "," << precise(p.precision) << "," << precise(p.recall)
                 << "," << p.tp << "," << p.fp << "\n";
    }
    plot.addLine(rx, py, plotColor(k), name + " (best F0.5 " + fixed(curve.best_f05, 3) + ")", 2);
    if (curve.best_f05 > 0.0)
      plot.addScatter({curve.best.recall}, {curve.best.precision}, plotColor(k), "", 7, MarkerShape::kDiamond);
    best_out << name << "," << precise(curve.best_f05) << "," << precise(curve.best.threshold) << ","
             << precise(curve.best.precision) << "," << precise(curve.best.recall) << "," << curve.best.tp << ","
             << curve.best.fp << "," << curve.positives << "," << curve.pairs << "\n";
    std::snprintf(buf, sizeof(buf), "   %-8s %8.4f %10.4f %10.4f %8zu %8zu %8.4g\n", name.c_str(), curve.best_f05,
                  curve.best.precision, curve.best.recall, curve.best.tp, curve.best.fp, curve.best.threshold);
    out << buf;
    std::string file_name = name;
    std::replace(file_name.begin(), file_name.end(), '-', '_');
    std::transform(file_name.begin(), file_name.end(), file_name.begin(), ::tolower);
    const std::string matrix_path = (fs::path(out_dir) / ("recognition_" + file_name + ".png")).string();
    writeOutcomeMatrixPng(outcomeMatrix(n, pairs, *scores, truth, curve.best.threshold),
                          name + ": recognition at the best F0.5 (" + fixed(curve.best_f05, 3) + ")", matrix_path);
    result.figures.push_back(matrix_path);
    result.curves.push_back(std::move(curve));
  }
  plot.setLegendLocation(LegendLocation::kTopRight);
  const std::string pr_png = (fs::path(out_dir) / "pr_curves.png").string();
  plot.savePng(pr_png);
  result.figures.insert(result.figures.begin(), pr_png);
  if (!curves_out || !best_out) throw std::runtime_error("cannot write the CSVs in '" + out_dir + "'");
  result.files = {curves_csv, best_csv};
  for (const auto& c : result.curves)
    out << "VIMS_PLACE_RECOGNITION method=" << c.method << " best_f05=" << fixed(c.best_f05, 4)
        << " precision=" << fixed(c.best.precision, 4) << " recall=" << fixed(c.best.recall, 4) << " tp=" << c.best.tp
        << " fp=" << c.best.fp << " positives=" << c.positives << " pairs=" << c.pairs << "\n";
  return result;
}

int runPlaceRecognitionCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& /*err*/) {
  const CliArgs a(args, 1,
                  {{"sequence", true},
                   {"orb-run", true},
                   {"brief-run", true},
                   {"out", true},
                   {"radius", true},
                   {"config", true},
                   {"package-root", true}},
                  "place-recognition");
  PlaceRecognitionInputs in;
  in.sequence_dir = a.required("sequence", "place-recognition");
  const std::string orb_run = a.required("orb-run", "place-recognition");
  const std::string brief_run = a.required("brief-run", "place-recognition");
  const std::string out_dir = a.required("out", "place-recognition");
  in.orb_map = (fs::path(orb_run) / "map.vimsmap").string();
  in.brief_map = (fs::path(brief_run) / "map.vimsmap").string();
  in.signatures_csv = (fs::path(orb_run) / "mag_signatures.csv").string();
  in.package_root = a.get("package-root", defaultPackageRoot());
  PlaceRecognitionOptions o;
  a.number("radius", &o.true_match_radius_m);
  if (!(o.true_match_radius_m > 0.0)) throw UsageError("place-recognition: --radius must be > 0");
  if (a.has("config")) {
    const double radius = o.true_match_radius_m;
    o = placeRecognitionOptionsFromConfig(a.get("config", ""));
    o.true_match_radius_m = radius;
  }
  for (const auto& path : {in.orb_map, in.brief_map, in.signatures_csv})
    if (!fs::exists(path)) throw std::runtime_error("missing input '" + path + "' (run vims_offline with --map-save)");
  runPlaceRecognition(in, o, out_dir, out);
  return kExitOk;
}

}  // namespace eval
}  // namespace vims
