#include "vims_eval/eval_options.h"

#include <cmath>
#include <stdexcept>

#include "vims_common/option_table.h"

namespace vims {
namespace eval {

std::vector<AlignmentMode> parseAlignmentList(const std::string& text) {
  if (text == "all") return {AlignmentMode::kSe3, AlignmentMode::kSim3, AlignmentMode::kPosYaw, AlignmentMode::kNone};
  return {parseAlignmentMode(text)};
}

const OptionTable<EvalOptions>& EvalOptions::optionTable() {
  using O = EvalOptions;
  const auto read_alignments = [](const ConfigReader& reader, const std::string& key, O& o) {
    const YAML::Node node = reader.node()[key];
    std::vector<AlignmentMode> modes;
    try {
      if (node.IsScalar()) {
        modes = parseAlignmentList(node.as<std::string>());
      } else if (node.IsSequence() && node.size() > 0) {
        for (const auto& item : node) modes.push_back(parseAlignmentMode(item.as<std::string>()));
      } else {
        throw std::invalid_argument("expected 'all', one alignment name or a non-empty list of them");
      }
    } catch (const std::invalid_argument& e) {
      throw reader.error(key, e.what());
    } catch (const YAML::Exception&) {
      throw reader.error(key, "expected alignment names");
    }
    o.trajectory.alignments = modes;
  };
  const auto alignments_yaml = [](const O& o) {
    std::string out = "[";
    for (std::size_t i = 0; i < o.trajectory.alignments.size(); ++i)
      out += std::string(i ? ", " : "") + alignmentModeName(o.trajectory.alignments[i]);
    return out + "]";
  };
  static const auto table =
      OptionTable<O>()
          .number(
              "max_dt_s", [](O& o) -> double& { return o.trajectory.association.max_dt_s; }, Bounds::nonNegative())
          .flag("interpolate", [](O& o) -> bool& { return o.trajectory.association.interpolate; })
          .number(
              "max_gt_gap_s", [](O& o) -> double& { return o.trajectory.association.max_gt_gap_s; }, Bounds::positive())
          .custom("align", read_alignments, alignments_yaml, "a list of se3, sim3, posyaw, none, or all")
          .number(
              "rpe_delta_m", [](O& o) -> double& { return o.trajectory.rpe_delta_m; }, Bounds::positive())
          .number(
              "loop_trans_tol_m", [](O& o) -> double& { return o.loops.trans_tol_m; }, Bounds::nonNegative())
          .number(
              "loop_rot_tol_deg", [](O& o) -> double& { return o.loops.rot_tol_deg; }, Bounds::closed(0.0, 180.0))
          .number(
              "revisit_radius_m", [](O& o) -> double& { return o.revisit.radius_m; }, Bounds::positive())
          .number(
              "revisit_gap_s", [](O& o) -> double& { return o.revisit.min_gap_s; }, Bounds::nonNegative())
          .number(
              "revisit_margin_s", [](O& o) -> double& { return o.revisit.margin_s; }, Bounds::nonNegative())
          .number(
              "revisit_coil_radius_m", [](O& o) -> double& { return o.revisit.coil_radius_m; }, Bounds::positive())
          .rule([](const O& o) {
            return violationIf(o.trajectory.alignments.empty(), "align", "at least one alignment is needed");
          });
  return table;
}

void EvalOptions::validate() const {
  if (const auto v = optionTable().firstViolation(*this)) throw std::invalid_argument(v->key + ": " + v->message);
  if (!(loops.max_gt_gap_s > 0.0) || !std::isfinite(loops.max_gt_gap_s)) {
    throw std::invalid_argument("max_gt_gap_s (loops): must be > 0");
  }
}

EvalOptions EvalOptions::fromReader(const ConfigReader& reader) {
  EvalOptions o = readOptions<EvalOptions>(reader);
  o.loops.max_gt_gap_s = o.trajectory.association.max_gt_gap_s;  // one gap rule for trajectories and loops
  return o;
}

std::string EvalOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace eval
}  // namespace vims
