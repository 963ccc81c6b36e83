#include "vims_estimator/factor_options.h"

#include <sstream>

namespace vims {

namespace {
/// Indents every line of a YAML block by two spaces (to nest it under a key).
std::string indent(const std::string& block) {
  std::istringstream in(block);
  std::ostringstream out;
  std::string line;
  while (std::getline(in, line)) out << "  " << line << "\n";
  return out.str();
}
}  // namespace

FactorOptions FactorOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"imu_preintegration", "reprojection", "sonar_depth", "marginalization"});
  FactorOptions o;
  o.imu_preintegration = ImuPreintegrationOptions::fromReader(reader.childOrEmpty("imu_preintegration"));
  o.reprojection = ReprojectionOptions::fromReader(reader.childOrEmpty("reprojection"));
  o.sonar_depth = SonarDepthOptions::fromReader(reader.childOrEmpty("sonar_depth"));
  o.marginalization = MarginalizationOptions::fromReader(reader.childOrEmpty("marginalization"));
  return o;
}

std::string FactorOptions::toYaml() const {
  std::ostringstream os;
  os << "imu_preintegration:\n"
     << indent(imu_preintegration.toYaml()) << "reprojection:\n"
     << indent(reprojection.toYaml()) << "sonar_depth:\n"
     << indent(sonar_depth.toYaml()) << "marginalization:\n"
     << indent(marginalization.toYaml());
  return os.str();
}

}  // namespace vims
