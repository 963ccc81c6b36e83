#include "vims_estimator/factors/reprojection_factor.h"

#include <cmath>
#include <sstream>

#include "vims_common/option_table.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

std::string toString(LensWeighting weighting) {
  switch (weighting) {
    case LensWeighting::kOn:
      return "on";
    case LensWeighting::kOff:
      return "off";
    case LensWeighting::kAuto:
      break;
  }
  return "auto";
}

const OptionTable<ReprojectionOptions>& ReprojectionOptions::optionTable() {
  using O = ReprojectionOptions;
  static const auto table = OptionTable<O>()
                                .number("pixel_sigma", &O::pixel_sigma, Bounds::positive())
                                .choice<LensWeighting>("lens_weighting", &O::lens_weighting,
                                                       {LensWeighting::kAuto, LensWeighting::kOn, LensWeighting::kOff},
                                                       [](LensWeighting w) { return toString(w); });
  return table;
}

ReprojectionOptions ReprojectionOptions::fromReader(const ConfigReader& reader) {
  return readOptions<ReprojectionOptions>(reader);
}

std::string ReprojectionOptions::toYaml() const { return optionTable().toYaml(*this); }

bool weighsThroughLens(LensWeighting weighting, DistortionModel model) {
  if (weighting == LensWeighting::kAuto) return model == DistortionModel::kEquidistant;
  return weighting == LensWeighting::kOn;
}

Eigen::Matrix2d pixelFromNormalizedJacobian(const CameraModel& camera, const Eigen::Vector2d& uv, bool through_lens) {
  const Eigen::Matrix2d focal = Eigen::Vector2d(camera.fx(), camera.fy()).asDiagonal();
  if (!through_lens) return focal;
  Eigen::Matrix2d d_distorted_d_uv;
  camera.distortNormalized(uv, &d_distorted_d_uv);
  return focal * d_distorted_d_uv;
}

Eigen::Vector2d reprojectionResidual(const FeatureObservation& anchor, const FeatureObservation& target,
                                     const Eigen::Isometry3d& T_l_bi, const Eigen::Isometry3d& T_l_bk,
                                     const Eigen::Isometry3d& T_b_c, double lambda, double td, ReprojectionJacobians* J,
                                     double* depth_in_target) {
  const Eigen::Matrix3d R_i = T_l_bi.linear();
  const Eigen::Matrix3d R_k = T_l_bk.linear();
  const Eigen::Matrix3d R_bc = T_b_c.linear();
  const Eigen::Vector3d p_bc = T_b_c.translation();

  Eigen::Vector3d db_dtd;
  const Eigen::Vector3d b_i = unitBearing(anchor, td, J ? &db_dtd : nullptr);
  const Eigen::Vector3d f_ci = lambda * b_i;
  const Eigen::Vector3d f_bi = R_bc * f_ci + p_bc;
  const Eigen::Vector3d f_l = R_i * f_bi + T_l_bi.translation();
  const Eigen::Vector3d f_bk = R_k.transpose() * (f_l - T_l_bk.translation());
  const Eigen::Vector3d f_ck = R_bc.transpose() * (f_bk - p_bc);
  const double z = f_ck.z();
  if (depth_in_target) *depth_in_target = z;

  const Eigen::Vector2d r = f_ck.head<2>() / z - correctedUv(target, td);
  if (J == nullptr) return r;

  Eigen::Matrix<double, 2, 3> P;
  P << 1.0 / z, 0.0, -f_ck.x() / (z * z),  //
      0.0, 1.0 / z, -f_ck.y() / (z * z);
  const Eigen::Matrix3d A = R_bc.transpose() * R_k.transpose();  // d f_ck / d f_l
  const Eigen::Matrix<double, 2, 3> PA = P * A;

  J->d_pose_anchor.leftCols<3>() = PA;
  J->d_pose_anchor.rightCols<3>() = -PA * R_i * so3::skew(f_bi);
  J->d_pose_target.leftCols<3>() = -PA;
  J->d_pose_target.rightCols<3>() = P * R_bc.transpose() * so3::skew(f_bk);
  J->d_extrinsic.leftCols<3>() = P * R_bc.transpose() * (R_k.transpose() * R_i - Eigen::Matrix3d::Identity());
  J->d_extrinsic.rightCols<3>() = P * (so3::skew(f_ck) - A * R_i * R_bc * so3::skew(f_ci));
  const Eigen::Matrix<double, 2, 3> PARR = PA * R_i * R_bc;  // d r / d f_ci
  J->d_lambda = PARR * b_i;
  J->d_td = PARR * (lambda * db_dtd) - target.velocity;
  return r;
}

ReprojectionFactor::ReprojectionFactor(const FeatureObservation& anchor, const FeatureObservation& target,
                                       const Eigen::Matrix2d& sqrt_information)
    : anchor_(anchor), target_(target), sqrt_information_(sqrt_information) {}

bool ReprojectionFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Isometry3d T_l_bi = poseBlockToIsometry(parameters[0]);
  const Eigen::Isometry3d T_l_bk = poseBlockToIsometry(parameters[1]);
  const Eigen::Isometry3d T_b_c = poseBlockToIsometry(parameters[2]);
  const double lambda = parameters[3][0];
  const double td = parameters[4][0];

  ReprojectionJacobians J;
  double z = 0.0;
  const Eigen::Vector2d r =
      reprojectionResidual(anchor_, target_, T_l_bi, T_l_bk, T_b_c, lambda, td, jacobians ? &J : nullptr, &z);
  if (!(z > kMinDepth) || !r.allFinite()) return false;
  Eigen::Map<Eigen::Vector2d>{residuals} = sqrt_information_ * r;
  if (!jacobians) return true;

  writePoseJacobian<2>(sqrt_information_ * J.d_pose_anchor, Eigen::Quaterniond(poseRotation(parameters[0])),
                       jacobians[0]);
  writePoseJacobian<2>(sqrt_information_ * J.d_pose_target, Eigen::Quaterniond(poseRotation(parameters[1])),
                       jacobians[1]);
  writePoseJacobian<2>(sqrt_information_ * J.d_extrinsic, Eigen::Quaterniond(poseRotation(parameters[2])),
                       jacobians[2]);
  if (jacobians[3]) Eigen::Map<Eigen::Vector2d>{jacobians[3]} = sqrt_information_ * J.d_lambda;
  if (jacobians[4]) Eigen::Map<Eigen::Vector2d>{jacobians[4]} = sqrt_information_ * J.d_td;
  return true;
}

}  // namespace vims
