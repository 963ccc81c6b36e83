#include "vims_eval/eval_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vims {
namespace eval {
namespace {

void requireFinitePositive(double v, const char* name) {
  if (!(v > 0.0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be positive");
}
void requireFiniteNonNegative(double v, const char* name) {
  if (!(v >= 0.0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be >= 0");
}

}  // namespace

std::vector<AlignmentMode> parseAlignmentList(const std::string& text) {
  if (text == "all") return {AlignmentMode::kSe3, AlignmentMode::kSim3, AlignmentMode::kPosYaw, AlignmentMode::kNone};
  return {parseAlignmentMode(text)};
}

void EvalOptions::validate() const {
  requireFiniteNonNegative(trajectory.association.max_dt_s, "max_dt_s");
  requireFinitePositive(trajectory.association.max_gt_gap_s, "max_gt_gap_s");
  requireFinitePositive(trajectory.rpe_delta_m, "rpe_delta_m");
  if (trajectory.alignments.empty()) throw std::invalid_argument("align: at least one alignment is needed");
  requireFiniteNonNegative(loops.trans_tol_m, "loop_trans_tol_m");
  requireFiniteNonNegative(loops.rot_tol_deg, "loop_rot_tol_deg");
  if (loops.rot_tol_deg > 180.0) throw std::invalid_argument("loop_rot_tol_deg must be <= 180");
  requireFinitePositive(loops.max_gt_gap_s, "max_gt_gap_s");
  requireFinitePositive(revisit.radius_m, "revisit_radius_m");
  requireFiniteNonNegative(revisit.min_gap_s, "revisit_gap_s");
  requireFiniteNonNegative(revisit.margin_s, "revisit_margin_s");
}

EvalOptions EvalOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"max_dt_s", "interpolate", "max_gt_gap_s", "align", "rpe_delta_m", "loop_trans_tol_m",
                            "loop_rot_tol_deg", "revisit_radius_m", "revisit_gap_s", "revisit_margin_s"});
  EvalOptions o;
  auto& assoc = o.trajectory.association;
  assoc.max_dt_s = reader.get<double>("max_dt_s", assoc.max_dt_s);
  requireNonNegative(reader, "max_dt_s", assoc.max_dt_s);
  assoc.interpolate = reader.get<bool>("interpolate", assoc.interpolate);
  assoc.max_gt_gap_s = reader.get<double>("max_gt_gap_s", assoc.max_gt_gap_s);
  requirePositive(reader, "max_gt_gap_s", assoc.max_gt_gap_s);
  o.loops.max_gt_gap_s = assoc.max_gt_gap_s;
  if (reader.has("align")) {
    o.trajectory.alignments.clear();
    const YAML::Node node = reader.node()["align"];
    try {
      if (node.IsScalar()) {
        o.trajectory.alignments = parseAlignmentList(node.as<std::string>());
      } else if (node.IsSequence() && node.size() > 0) {
        for (const auto& item : node) o.trajectory.alignments.push_back(parseAlignmentMode(item.as<std::string>()));
      } else {
        throw std::invalid_argument("expected 'all', one alignment name or a non-empty list of them");
      }
    } catch (const std::invalid_argument& e) {
      throw reader.error("align", e.what());
    } catch (const YAML::Exception&) {
      throw reader.error("align", "expected alignment names");
    }
  }
  o.trajectory.rpe_delta_m = reader.get<double>("rpe_delta_m", o.trajectory.rpe_delta_m);
  requirePositive(reader, "rpe_delta_m", o.trajectory.rpe_delta_m);
  o.loops.trans_tol_m = reader.get<double>("loop_trans_tol_m", o.loops.trans_tol_m);
  requireNonNegative(reader, "loop_trans_tol_m", o.loops.trans_tol_m);
  o.loops.rot_tol_deg = reader.get<double>("loop_rot_tol_deg", o.loops.rot_tol_deg);
  requireInRange(reader, "loop_rot_tol_deg", o.loops.rot_tol_deg, 0.0, 180.0);
  o.revisit.radius_m = reader.get<double>("revisit_radius_m", o.revisit.radius_m);
  requirePositive(reader, "revisit_radius_m", o.revisit.radius_m);
  o.revisit.min_gap_s = reader.get<double>("revisit_gap_s", o.revisit.min_gap_s);
  requireNonNegative(reader, "revisit_gap_s", o.revisit.min_gap_s);
  o.revisit.margin_s = reader.get<double>("revisit_margin_s", o.revisit.margin_s);
  requireNonNegative(reader, "revisit_margin_s", o.revisit.margin_s);
  return o;
}

std::string EvalOptions::toYaml() const {
  std::ostringstream os;
  os << "max_dt_s: " << trajectory.association.max_dt_s << "\n"
     << "interpolate: " << (trajectory.association.interpolate ? "true" : "false") << "\n"
     << "max_gt_gap_s: " << trajectory.association.max_gt_gap_s << "\n"
     << "align: [";
  for (std::size_t i = 0; i < trajectory.alignments.size(); ++i)
    os << (i ? ", " : "") << alignmentModeName(trajectory.alignments[i]);
  os << "]\n"
     << "rpe_delta_m: " << trajectory.rpe_delta_m << "\n"
     << "loop_trans_tol_m: " << loops.trans_tol_m << "\n"
     << "loop_rot_tol_deg: " << loops.rot_tol_deg << "\n"
     << "revisit_radius_m: " << revisit.radius_m << "\n"
     << "revisit_gap_s: " << revisit.min_gap_s << "\n"
     << "revisit_margin_s: " << revisit.margin_s << "\n";
  return os.str();
}

}  // namespace eval
}  // namespace vims
