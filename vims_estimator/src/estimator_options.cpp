#include "vims_estimator/estimator_options.h"

#include <sstream>

namespace vims {

EstimatorOptions EstimatorOptions::fromReader(const ConfigReader& r) {
  r.rejectUnknownKeys({"window_size",
                       "keyframe_parallax_px",
                       "keyframe_min_tracked",
                       "max_solver_iterations",
                       "max_solver_time_s",
                       "reprojection_loss_scale",
                       "sonar_loss_scale",
                       "min_feature_depth_m",
                       "max_feature_depth_m",
                       "triangulation_min_angle_deg",
                       "outlier_reprojection_px",
                       "use_sonar",
                       "sonar_max_interpolation_gap_s",
                       "sonar_wait_s",
                       "sonar_min_range_std_m",
                       "estimate_td",
                       "td_initial_s",
                       "max_abs_td_s",
                       "td_min_image_speed_px_s",
                       "init_gravity_window_s",
                       "init_static_gyro_std",
                       "init_static_accel_std",
                       "init_velocity_sigma",
                       "init_accel_bias_sigma",
                       "init_gyro_bias_sigma",
                       "imu_max_gap_s",
                       "max_frame_wait_s",
                       "failure_max_accel_bias",
                       "failure_max_gyro_bias",
                       "failure_max_position_jump_m",
                       "failure_max_velocity",
                       "failure_min_tracked",
                       "failure_lost_tracking_s",
                       "factors",
                       "solve_window_every_frame",
                       "visual_inertial_init",
                       "seabed",
                       "pressure"});
  EstimatorOptions o;
  o.window_size = r.get<int>("window_size", o.window_size);
  requireInRange(r, "window_size", o.window_size, 2, 50);
  o.keyframe_parallax_px = r.get<double>("keyframe_parallax_px", o.keyframe_parallax_px);
  requirePositive(r, "keyframe_parallax_px", o.keyframe_parallax_px);
  o.keyframe_min_tracked = r.get<int>("keyframe_min_tracked", o.keyframe_min_tracked);
  requireNonNegative(r, "keyframe_min_tracked", o.keyframe_min_tracked);
  o.max_solver_iterations = r.get<int>("max_solver_iterations", o.max_solver_iterations);
  requireInRange(r, "max_solver_iterations", o.max_solver_iterations, 1, 1000);
  o.max_solver_time_s = r.get<double>("max_solver_time_s", o.max_solver_time_s);
  requireNonNegative(r, "max_solver_time_s", o.max_solver_time_s);
  o.solve_window_every_frame = r.get<bool>("solve_window_every_frame", o.solve_window_every_frame);
  o.reprojection_loss_scale = r.get<double>("reprojection_loss_scale", o.reprojection_loss_scale);
  requirePositive(r, "reprojection_loss_scale", o.reprojection_loss_scale);
  o.sonar_loss_scale = r.get<double>("sonar_loss_scale", o.sonar_loss_scale);
  requirePositive(r, "sonar_loss_scale", o.sonar_loss_scale);
  o.min_feature_depth_m = r.get<double>("min_feature_depth_m", o.min_feature_depth_m);
  requirePositive(r, "min_feature_depth_m", o.min_feature_depth_m);
  o.max_feature_depth_m = r.get<double>("max_feature_depth_m", o.max_feature_depth_m);
  if (!(o.max_feature_depth_m > o.min_feature_depth_m)) {
    throw r.error("max_feature_depth_m", "must be larger than min_feature_depth_m");
  }
  o.triangulation_min_angle_deg = r.get<double>("triangulation_min_angle_deg", o.triangulation_min_angle_deg);
  requireInRange(r, "triangulation_min_angle_deg", o.triangulation_min_angle_deg, 0.01, 45.0);
  o.outlier_reprojection_px = r.get<double>("outlier_reprojection_px", o.outlier_reprojection_px);
  requirePositive(r, "outlier_reprojection_px", o.outlier_reprojection_px);
  o.use_sonar = r.get<bool>("use_sonar", o.use_sonar);
  o.sonar_max_interpolation_gap_s = r.get<double>("sonar_max_interpolation_gap_s", o.sonar_max_interpolation_gap_s);
  requirePositive(r, "sonar_max_interpolation_gap_s", o.sonar_max_interpolation_gap_s);
  readInRange(r, "sonar_wait_s", &o.sonar_wait_s, 0.0, 5.0);
  o.sonar_min_range_std_m = r.get<double>("sonar_min_range_std_m", o.sonar_min_range_std_m);
  requirePositive(r, "sonar_min_range_std_m", o.sonar_min_range_std_m);
  o.estimate_td = r.get<bool>("estimate_td", o.estimate_td);
  o.max_abs_td_s = r.get<double>("max_abs_td_s", o.max_abs_td_s);
  requireInRange(r, "max_abs_td_s", o.max_abs_td_s, 1e-6, 0.5);
  o.td_min_image_speed_px_s = r.get<double>("td_min_image_speed_px_s", o.td_min_image_speed_px_s);
  requireNonNegative(r, "td_min_image_speed_px_s", o.td_min_image_speed_px_s);
  o.td_initial_s = r.get<double>("td_initial_s", o.td_initial_s);
  requireInRange(r, "td_initial_s", o.td_initial_s, -o.max_abs_td_s, o.max_abs_td_s);
  o.init_gravity_window_s = r.get<double>("init_gravity_window_s", o.init_gravity_window_s);
  requireInRange(r, "init_gravity_window_s", o.init_gravity_window_s, 0.05, 10.0);
  o.init_static_gyro_std = r.get<double>("init_static_gyro_std", o.init_static_gyro_std);
  requirePositive(r, "init_static_gyro_std", o.init_static_gyro_std);
  o.init_static_accel_std = r.get<double>("init_static_accel_std", o.init_static_accel_std);
  requirePositive(r, "init_static_accel_std", o.init_static_accel_std);
  o.init_velocity_sigma = r.get<double>("init_velocity_sigma", o.init_velocity_sigma);
  requirePositive(r, "init_velocity_sigma", o.init_velocity_sigma);
  o.init_accel_bias_sigma = r.get<double>("init_accel_bias_sigma", o.init_accel_bias_sigma);
  requirePositive(r, "init_accel_bias_sigma", o.init_accel_bias_sigma);
  o.init_gyro_bias_sigma = r.get<double>("init_gyro_bias_sigma", o.init_gyro_bias_sigma);
  requirePositive(r, "init_gyro_bias_sigma", o.init_gyro_bias_sigma);
  o.imu_max_gap_s = r.get<double>("imu_max_gap_s", o.imu_max_gap_s);
  requirePositive(r, "imu_max_gap_s", o.imu_max_gap_s);
  o.max_frame_wait_s = r.get<double>("max_frame_wait_s", o.max_frame_wait_s);
  requirePositive(r, "max_frame_wait_s", o.max_frame_wait_s);
  o.failure_max_accel_bias = r.get<double>("failure_max_accel_bias", o.failure_max_accel_bias);
  requirePositive(r, "failure_max_accel_bias", o.failure_max_accel_bias);
  o.failure_max_gyro_bias = r.get<double>("failure_max_gyro_bias", o.failure_max_gyro_bias);
  requirePositive(r, "failure_max_gyro_bias", o.failure_max_gyro_bias);
  o.failure_max_position_jump_m = r.get<double>("failure_max_position_jump_m", o.failure_max_position_jump_m);
  requirePositive(r, "failure_max_position_jump_m", o.failure_max_position_jump_m);
  o.failure_max_velocity = r.get<double>("failure_max_velocity", o.failure_max_velocity);
  requirePositive(r, "failure_max_velocity", o.failure_max_velocity);
  o.failure_min_tracked = r.get<int>("failure_min_tracked", o.failure_min_tracked);
  requireNonNegative(r, "failure_min_tracked", o.failure_min_tracked);
  o.failure_lost_tracking_s = r.get<double>("failure_lost_tracking_s", o.failure_lost_tracking_s);
  requirePositive(r, "failure_lost_tracking_s", o.failure_lost_tracking_s);
  o.factors = FactorOptions::fromReader(r.childOrEmpty("factors"));
  o.visual_inertial_init = VisualInertialInitOptions::fromReader(r.childOrEmpty("visual_inertial_init"));
  o.seabed = SeabedModelOptions::fromReader(r.childOrEmpty("seabed"));
  o.pressure = PressureOptions::fromReader(r.childOrEmpty("pressure"));
  return o;
}

std::string EstimatorOptions::toYaml() const {
  std::ostringstream os;
  os << "window_size: " << window_size << "\nkeyframe_parallax_px: " << keyframe_parallax_px
     << "\nkeyframe_min_tracked: " << keyframe_min_tracked << "\nmax_solver_iterations: " << max_solver_iterations
     << "\nmax_solver_time_s: " << max_solver_time_s
     << "\nsolve_window_every_frame: " << (solve_window_every_frame ? "true" : "false")
     << "\nreprojection_loss_scale: " << reprojection_loss_scale << "\nsonar_loss_scale: " << sonar_loss_scale
     << "\nmin_feature_depth_m: " << min_feature_depth_m << "\nmax_feature_depth_m: " << max_feature_depth_m
     << "\ntriangulation_min_angle_deg: " << triangulation_min_angle_deg
     << "\noutlier_reprojection_px: " << outlier_reprojection_px << "\nuse_sonar: " << (use_sonar ? "true" : "false")
     << "\nsonar_max_interpolation_gap_s: " << sonar_max_interpolation_gap_s << "\nsonar_wait_s: " << sonar_wait_s
     << "\nsonar_min_range_std_m: " << sonar_min_range_std_m << "\nestimate_td: " << (estimate_td ? "true" : "false")
     << "\ntd_initial_s: " << td_initial_s << "\nmax_abs_td_s: " << max_abs_td_s
     << "\ntd_min_image_speed_px_s: " << td_min_image_speed_px_s << "\ninit_gravity_window_s: " << init_gravity_window_s
     << "\ninit_static_gyro_std: " << init_static_gyro_std << "\ninit_static_accel_std: " << init_static_accel_std
     << "\ninit_velocity_sigma: " << init_velocity_sigma << "\ninit_accel_bias_sigma: " << init_accel_bias_sigma
     << "\ninit_gyro_bias_sigma: " << init_gyro_bias_sigma << "\nimu_max_gap_s: " << imu_max_gap_s
     << "\nmax_frame_wait_s: " << max_frame_wait_s << "\nfailure_max_accel_bias: " << failure_max_accel_bias
     << "\nfailure_max_gyro_bias: " << failure_max_gyro_bias
     << "\nfailure_max_position_jump_m: " << failure_max_position_jump_m
     << "\nfailure_max_velocity: " << failure_max_velocity << "\nfailure_min_tracked: " << failure_min_tracked
     << "\nfailure_lost_tracking_s: " << failure_lost_tracking_s << "\nfactors:\n";
  std::istringstream in(factors.toYaml());
  std::string line;
  while (std::getline(in, line)) os << "  " << line << "\n";
  os << "visual_inertial_init:\n";
  std::istringstream init_in(visual_inertial_init.toYaml());
  while (std::getline(init_in, line)) os << "  " << line << "\n";
  os << "seabed:\n";
  std::istringstream seabed_in(seabed.toYaml());
  while (std::getline(seabed_in, line)) os << "  " << line << "\n";
  os << "pressure:\n";
  std::istringstream pressure_in(pressure.toYaml());
  while (std::getline(pressure_in, line)) os << "  " << line << "\n";
  return os.str();
}

}  // namespace vims
