#include "vims_estimator/estimator_options.h"

#include <cmath>

#include "vims_common/option_table.h"

namespace vims {

namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

const OptionTable<EstimatorOptions>& EstimatorOptions::optionTable() {
  using O = EstimatorOptions;
  static const auto table =
      OptionTable<O>()
          .integer("window_size", &O::window_size, Bounds::closed(2, 50))
          .number("keyframe_parallax_px", &O::keyframe_parallax_px, Bounds::positive())
          .integer("keyframe_min_tracked", &O::keyframe_min_tracked, Bounds::nonNegative())
          .integer("max_solver_iterations", &O::max_solver_iterations, Bounds::closed(1, 1000))
          .number("max_solver_time_s", &O::max_solver_time_s, Bounds::nonNegative())
          .flag("solve_window_every_frame", &O::solve_window_every_frame)
          .number("reprojection_loss_scale", &O::reprojection_loss_scale, Bounds::positive())
          .number("sonar_loss_scale", &O::sonar_loss_scale, Bounds::positive())
          .number("min_feature_depth_m", &O::min_feature_depth_m, Bounds::positive())
          .number("max_feature_depth_m", &O::max_feature_depth_m, Bounds::positive())
          .number("triangulation_min_angle_deg", &O::triangulation_min_angle_deg, Bounds::closed(0.01, 45.0))
          .number("outlier_reprojection_px", &O::outlier_reprojection_px, Bounds::positive())
          .flag("use_sonar", &O::use_sonar)
          .number("sonar_max_interpolation_gap_s", &O::sonar_max_interpolation_gap_s, Bounds::positive())
          .number("sonar_wait_s", &O::sonar_wait_s, Bounds::closed(0.0, 5.0))
          .number("sonar_min_range_std_m", &O::sonar_min_range_std_m, Bounds::positive())
          .flag("estimate_td", &O::estimate_td)
          .number("td_initial_s", &O::td_initial_s, Bounds::closed(-0.5, 0.5))
          .number("max_abs_td_s", &O::max_abs_td_s, Bounds::closed(1e-6, 0.5))
          .number("td_min_image_speed_px_s", &O::td_min_image_speed_px_s, Bounds::nonNegative())
          .flag("estimate_extrinsic", &O::estimate_extrinsic)
          .scaledNumber("extrinsic_prior_rotation_deg", &O::extrinsic_prior_rotation_rad, kDeg,
                        Bounds::closed(1e-3, 30.0))
          .number("extrinsic_prior_translation_m", &O::extrinsic_prior_translation_m, Bounds::closed(1e-4, 1.0))
          .number("init_gravity_window_s", &O::init_gravity_window_s, Bounds::closed(0.05, 10.0))
          .number("init_static_gyro_std", &O::init_static_gyro_std, Bounds::positive())
          .number("init_static_accel_std", &O::init_static_accel_std, Bounds::positive())
          .number("init_velocity_sigma", &O::init_velocity_sigma, Bounds::positive())
          .number("init_accel_bias_sigma", &O::init_accel_bias_sigma, Bounds::positive())
          .number("init_gyro_bias_sigma", &O::init_gyro_bias_sigma, Bounds::positive())
          .number("imu_max_gap_s", &O::imu_max_gap_s, Bounds::positive())
          .number("max_frame_wait_s", &O::max_frame_wait_s, Bounds::positive())
          .number("failure_max_accel_bias", &O::failure_max_accel_bias, Bounds::positive())
          .number("failure_max_gyro_bias", &O::failure_max_gyro_bias, Bounds::positive())
          .number("failure_max_position_jump_m", &O::failure_max_position_jump_m, Bounds::positive())
          .number("failure_max_velocity", &O::failure_max_velocity, Bounds::positive())
          .integer("failure_min_tracked", &O::failure_min_tracked, Bounds::nonNegative())
          .number("failure_lost_tracking_s", &O::failure_lost_tracking_s, Bounds::positive())
          .section<FactorOptions>("factors", &O::factors, FactorOptions::optionTable())
          .section<VisualInertialInitOptions>("visual_inertial_init", &O::visual_inertial_init,
                                              VisualInertialInitOptions::optionTable())
          .section<SeabedModelOptions>("seabed", &O::seabed, SeabedModelOptions::optionTable())
          .section<PressureOptions>("pressure", &O::pressure, PressureOptions::optionTable())
          .rule([](const O& o) {
            return violationIf(!(o.max_feature_depth_m > o.min_feature_depth_m), "max_feature_depth_m",
                               "must be larger than min_feature_depth_m");
          })
          .rule([](const O& o) {
            return violationIf(std::abs(o.td_initial_s) > o.max_abs_td_s, "td_initial_s",
                               "must be within +-max_abs_td_s (" + formatOptionNumber(o.max_abs_td_s) + "), got " +
                                   formatOptionNumber(o.td_initial_s));
          });
  return table;
}

EstimatorOptions EstimatorOptions::fromReader(const ConfigReader& r) { return readOptions<EstimatorOptions>(r); }

std::string EstimatorOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
