#include "vims_estimator/factor_options.h"

#include "vims_common/option_table.h"

namespace vims {

const OptionTable<FactorOptions>& FactorOptions::optionTable() {
  using O = FactorOptions;
  static const auto table =
      OptionTable<O>()
          .section<ImuPreintegrationOptions>("imu_preintegration", &O::imu_preintegration,
                                             ImuPreintegrationOptions::optionTable())
          .section<ReprojectionOptions>("reprojection", &O::reprojection, ReprojectionOptions::optionTable())
          .section<SonarDepthOptions>("sonar_depth", &O::sonar_depth, SonarDepthOptions::optionTable())
          .section<MarginalizationOptions>("marginalization", &O::marginalization,
                                           MarginalizationOptions::optionTable());
  return table;
}

FactorOptions FactorOptions::fromReader(const ConfigReader& reader) { return readOptions<FactorOptions>(reader); }

std::string FactorOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
