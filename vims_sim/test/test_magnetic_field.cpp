// The coil dipole against analytic on-axis/equatorial values and a Biot-Savart integration of
// a current loop; the geomagnetic field; the magnetometer frame handling.
#include <gtest/gtest.h>

#include <cmath>

#include "vims_sim/magnetic_field.h"
#include "vims_sim/sensor_models.h"

using namespace vims::sim;

namespace {

/// Field of a circular loop (centre c, axis +z, radius a, total ampere-turns NI) at p by
/// numerical Biot-Savart: dB = mu0 NI / (4 pi) dl x r / |r|^3.
Eigen::Vector3d biotSavartLoop(const Eigen::Vector3d& c, double a, double ampere_turns, const Eigen::Vector3d& p,
                               int segments = 20000) {
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int i = 0; i < segments; ++i) {
    const double phi0 = 2.0 * M_PI * i / segments, phi1 = 2.0 * M_PI * (i + 1) / segments;
    const Eigen::Vector3d q0 = c + a * Eigen::Vector3d(std::cos(phi0), std::sin(phi0), 0.0);
    const Eigen::Vector3d q1 = c + a * Eigen::Vector3d(std::cos(phi1), std::sin(phi1), 0.0);
    const Eigen::Vector3d dl = q1 - q0;
    const Eigen::Vector3d r = p - 0.5 * (q0 + q1);
    b += dl.cross(r) / std::pow(r.norm(), 3);
  }
  return kMu0 * ampere_turns / (4.0 * M_PI) * b;
}

CoilDipole referenceCoil() {
  CoilDipole coil;
  coil.position_w = Eigen::Vector3d(1.5, -2.0, 0.0);
  coil.turns = 330;
  coil.current = 2.9;
  coil.diameter = 0.6;
  coil.frequency = 11.0;
  coil.phase = 0.4;
  return coil;
}

}  // namespace

TEST(CoilDipole, MomentOfTheReferenceCoil) {
  const CoilDipole coil = referenceCoil();
  // 330 turns * 2.9 A * pi * 0.3^2 m^2 = 270.6 A m^2, vertical.
  EXPECT_NEAR(coil.peakMoment().z(), 330 * 2.9 * M_PI * 0.09, 1e-9);
  EXPECT_EQ(coil.peakMoment().head<2>().norm(), 0.0);
}

TEST(CoilDipole, OnAxisAndEquatorialValues) {
  const CoilDipole coil = referenceCoil();
  const double m = coil.peakMoment().z();
  for (double r : {2.0, 3.0, 5.0}) {
    // On the axis above the coil: B = mu0 m / (2 pi r^3), along +z.
    const Eigen::Vector3d on_axis = coil.peakField(coil.position_w + Eigen::Vector3d(0, 0, r));
    EXPECT_NEAR(on_axis.z(), kMu0 * m / (2.0 * M_PI * r * r * r), 1e-18);
    EXPECT_NEAR(on_axis.head<2>().norm(), 0.0, 1e-20);
    // In the coil plane: B = -mu0 m / (4 pi r^3), along -z.
    const Eigen::Vector3d equator = coil.peakField(coil.position_w + Eigen::Vector3d(r * 0.6, r * 0.8, 0));
    EXPECT_NEAR(equator.z(), -kMu0 * m / (4.0 * M_PI * r * r * r), 1e-18);
    EXPECT_NEAR(equator.head<2>().norm(), 0.0, 1e-20);
  }
  // 3 m above the coil the peak field is about 2 uT: well above the 5 nT sensor noise.
  EXPECT_NEAR(coil.peakField(coil.position_w + Eigen::Vector3d(0, 0, 3)).z(), 2.0e-6, 0.01e-6);
}

TEST(CoilDipole, MatchesBiotSavartOfASmallLoop) {
  // A small loop is a pure dipole: the analytic formula must match to the discretisation error.
  CoilDipole coil = referenceCoil();
  coil.diameter = 0.02;
  const double ampere_turns = coil.turns * coil.current;
  for (const Eigen::Vector3d& offset : {Eigen::Vector3d(0.3, 0.1, 0.5), Eigen::Vector3d(-0.7, 0.4, 0.2),
                                        Eigen::Vector3d(0.2, -0.9, -0.4), Eigen::Vector3d(1.0, 0.0, 0.0)}) {
    const Eigen::Vector3d p = coil.position_w + offset;
    const Eigen::Vector3d reference = biotSavartLoop(coil.position_w, 0.5 * coil.diameter, ampere_turns, p);
    EXPECT_LT((coil.peakField(p) - reference).norm(), 1e-3 * reference.norm()) << offset.transpose();
  }
}

TEST(CoilDipole, RealCoilIsADipoleAtSurveyDistances) {
  // The 0.6 m coil seen from 2-5 m: the dipole's relative error is of order (a / r)^2.
  const CoilDipole coil = referenceCoil();
  const double a = 0.5 * coil.diameter;
  for (const Eigen::Vector3d& offset : {Eigen::Vector3d(0, 0, 2.0), Eigen::Vector3d(1.5, 1.0, 3.0),
                                        Eigen::Vector3d(-3.0, 2.0, 2.5), Eigen::Vector3d(4.0, 0.0, 2.0)}) {
    const Eigen::Vector3d p = coil.position_w + offset;
    const Eigen::Vector3d reference = biotSavartLoop(coil.position_w, a, coil.turns * coil.current, p);
    const double r = offset.norm();
    EXPECT_LT((coil.peakField(p) - reference).norm(), 3.0 * (a / r) * (a / r) * reference.norm()) << offset.transpose();
  }
}

TEST(CoilDipole, InstantaneousFieldIsThePeakTimesTheWaveform) {
  const CoilDipole coil = referenceCoil();
  const Eigen::Vector3d p(0.0, 0.0, 3.0);
  for (double t : {0.0, 0.01, 0.0227, 1.5}) {
    const double w = std::sin(2.0 * M_PI * 11.0 * t + 0.4);
    EXPECT_LT((coil.field(p, t) - w * coil.peakField(p)).norm(), 1e-20);
  }
}

TEST(GeomagneticField, EnuComponentsFromIntensityInclinationDeclination) {
  GeomagneticField geo;
  geo.total = 49e-6;
  geo.inclination_deg = 46.0;
  geo.declination_deg = 0.0;
  Eigen::Vector3d b = geo.fieldEnu();
  EXPECT_NEAR(b.norm(), 49e-6, 1e-15);
  EXPECT_NEAR(b.x(), 0.0, 1e-15);
  EXPECT_NEAR(b.y(), 49e-6 * std::cos(46.0 * M_PI / 180), 1e-15);
  EXPECT_NEAR(b.z(), -49e-6 * std::sin(46.0 * M_PI / 180), 1e-15);  // pointing down
  geo.declination_deg = 4.0;                                        // magnetic north 4 deg east of true north
  b = geo.fieldEnu();
  EXPECT_NEAR(std::atan2(b.x(), b.y()) * 180 / M_PI, 4.0, 1e-9);
  EXPECT_NEAR(std::atan2(-b.z(), b.head<2>().norm()) * 180 / M_PI, 46.0, 1e-9);
}

TEST(Magnetometer, MeasuresTheFieldInItsOwnFrame) {
  GeomagneticField geo;
  geo.declination_deg = 3.0;
  const CoilDipole coil = referenceCoil();
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  T_w_b.translation() = Eigen::Vector3d(0.5, -1.0, 3.0);
  Eigen::Isometry3d T_b_m = Eigen::Isometry3d::Identity();
  T_b_m.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T_b_m.translation() = Eigen::Vector3d(-0.35, 0.0, 0.05);
  const double t = 0.0123;
  const Eigen::Isometry3d T_w_m = T_w_b * T_b_m;
  const Eigen::Vector3d expected = T_w_m.linear().transpose() * (geo.fieldEnu() + coil.field(T_w_m.translation(), t));
  const MagneticWorld world{geo.fieldEnu(), coil, std::nullopt, {}};
  EXPECT_LT((MagnetometerSimulator::trueField(T_w_b, T_b_m, world, t) - expected).norm(), 1e-18);
  // Noise: 5 nT per axis and sample.
  MagnetometerParams params;
  MagnetometerSimulator mag(params, T_b_m, world, 42);
  double sum2 = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) sum2 += (mag.measure(T_w_b, t) - expected).squaredNorm();
  EXPECT_NEAR(std::sqrt(sum2 / (3.0 * n)), 5e-9, 0.1e-9);
}

TEST(MagneticAnomaly, InducedAlongTheFieldWithTheRequestedPeakAndAnInverseCubeFalloff) {
  GeomagneticField geo;
  geo.declination_deg = -4.0;
  const Eigen::Vector3d above(3.0, -2.0, 1.5);
  const MagneticAnomaly a = MagneticAnomaly::induced(above, 5.0, 2.0e-6, geo.fieldEnu());
  EXPECT_LT((a.position_w - Eigen::Vector3d(3.0, -2.0, -3.5)).norm(), 1e-12);
  EXPECT_NEAR(a.moment_enu.normalized().dot(geo.fieldEnu().normalized()), 1.0, 1e-12);
  EXPECT_NEAR(a.field(above).norm(), 2.0e-6, 1e-15);
  // Twice as far along the same ray: an eighth of the field, same direction.
  const Eigen::Vector3d farther = a.position_w + 2.0 * (above - a.position_w);
  EXPECT_LT((a.field(farther) * 8.0 - a.field(above)).norm(), 1e-15);
  // The world adds it to the constant geomagnetic field; 500 m away it is down by (5/500)^3 = 1e-6.
  const MagneticWorld world{geo.fieldEnu(), CoilDipole{}, a, {}};
  const Eigen::Vector3d far_away(400.0, 300.0, 1.5);
  EXPECT_LT((world.fieldEnu(far_away, 0.0) - geo.fieldEnu() - world.coil.field(far_away, 0.0)).norm(), 4e-12);
}

TEST(CoilDipole, ADriftingCoilsPhaseIsTheIntegralOfItsFrequency) {
  CoilDipole coil;
  coil.frequency = 11.0;
  coil.frequency_rate = 0.1 / 600.0;  // +0.1 Hz over ten minutes
  coil.phase = 0.3;
  // Zero crossings going up, found by bisection, are one period of the instantaneous frequency apart.
  auto upCrossingAfter = [&](double t) {
    double lo = t, step = 1e-3;
    while (!(coil.waveform(lo) < 0.0 && coil.waveform(lo + step) >= 0.0)) lo += step;
    double hi = lo + step;
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (coil.waveform(mid) < 0.0 ? lo : hi) = mid;
    }
    return hi;
  };
  for (double t : {0.0, 300.0, 600.0}) {
    const double a = upCrossingAfter(t), b = upCrossingAfter(a + 1e-3);
    EXPECT_NEAR(1.0 / (b - a), 11.0 + coil.frequency_rate * 0.5 * (a + b), 1e-6) << "t=" << t;
  }
  coil.frequency_rate = 0.0;
  EXPECT_NEAR(coil.waveform(2.0), std::sin(2.0 * M_PI * 11.0 * 2.0 + 0.3), 1e-12);
}

TEST(ThrusterInterference, ThrustFollowsDragAndInertiaAndTheLineItsSquareRoot) {
  ThrusterInterference th;  // 0.5 m/s reference, 45 Hz, inertia length 3.3 m
  TrajectoryState s;
  s.q_w_b = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));  // heading does not matter
  const Eigen::Vector3d forward = s.q_w_b * Eigen::Vector3d::UnitX();
  EXPECT_EQ(th.relativeThrust(s), 0.0);  // at rest: motors idle
  s.v_w_b = 0.5 * forward;
  EXPECT_NEAR(th.relativeThrust(s), 1.0, 1e-12);
  EXPECT_NEAR(th.lineFrequency(0, 1.0), 45.0, 1e-12);
  EXPECT_NEAR(th.lineFrequency(1, 1.0), 45.0 * 1.04, 1e-12);
  s.v_w_b = 0.25 * forward;
  EXPECT_NEAR(th.relativeThrust(s), 0.25, 1e-12);       // drag ~ v^2
  EXPECT_NEAR(th.lineFrequency(0, 0.25), 22.5, 1e-12);  // RPM ~ sqrt(thrust)
  s.a_w_b = 0.02 * forward;                             // accelerating adds m a
  EXPECT_NEAR(th.relativeThrust(s), 0.25 + 3.3 * 0.02 / 0.25, 1e-12);
  s.a_w_b = -0.1 * forward;  // braking harder than drag: the propellers do not pull
  EXPECT_EQ(th.relativeThrust(s), 0.0);
}

TEST(ThrusterInterference, TheMagnetometerSeesTheLinesTheOffsetAndTheNoise) {
  ThrusterInterference th;
  th.broadband_std_tesla = 0.0;
  th.line_amplitude_tesla = 1e-7;
  th.hard_iron_tesla = 2e-6;
  th.line_direction_m = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()};
  th.hard_iron_direction_m = Eigen::Vector3d::UnitZ();
  MagnetometerSimulator mag(MagnetometerParams{}, Eigen::Isometry3d::Identity(), MagneticWorld{}, 1);
  mag.setThrusters(th);
  TrajectoryState s;
  s.v_w_b = Eigen::Vector3d(0.5, 0.0, 0.0);  // the reference thrust: lines at 45 and 46.8 Hz
  // One second at 1 kHz: the offset is the reference's, each line's zero crossings its frequency.
  int crossings_x = 0, crossings_y = 0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (int k = 0; k <= 1000; ++k) {
    s.t = 1e-3 * k;
    const Eigen::Vector3d f = mag.thrusterField(s);
    EXPECT_NEAR(f.z(), 2e-6, 1e-15);
    EXPECT_LE(f.head<2>().cwiseAbs().maxCoeff(), 1e-7 + 1e-15);
    if (k > 0) {
      crossings_x += (previous.x() < 0.0) != (f.x() < 0.0);
      crossings_y += (previous.y() < 0.0) != (f.y() < 0.0);
    }
    previous = f;
  }
  EXPECT_NEAR(crossings_x, 90, 1);  // two per period
  EXPECT_NEAR(crossings_y, 93.6, 1.5);
}

TEST(MagneticWorld, SumsTheFieldsOfEveryCoil) {
  GeomagneticField geo;
  CoilDipole first = referenceCoil();
  CoilDipole second = first;
  second.position_w = Eigen::Vector3d(25.0, -16.0, 0.0);
  second.frequency = 17.0;
  second.phase = 1.1;
  CoilDipole third = first;
  third.position_w = Eigen::Vector3d(-20.0, 14.0, -0.4);
  third.frequency = 23.0;
  third.phase = 4.2;
  MagneticWorld world{geo.fieldEnu(), first, std::nullopt, {second, third}};
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.5, -1.0, 3.0), Eigen::Vector3d(24.0, -15.0, 2.0), Eigen::Vector3d(-19.0, 13.0, 1.5)}) {
    for (const double t : {0.0, 0.0123, 0.31}) {
      const Eigen::Vector3d expected = geo.fieldEnu() + first.field(p, t) + second.field(p, t) + third.field(p, t);
      EXPECT_LT((world.fieldEnu(p, t) - expected).norm(), 1e-18);
    }
  }
  // Next to the second coil its field dominates: the magnetometer sees it.
  const Eigen::Vector3d near_second(25.0, -16.0, 2.0);
  EXPECT_GT(second.peakField(near_second).norm(), 100.0 * first.peakField(near_second).norm());
  const double t = 0.5 / 17.0 / 2.0 - second.phase / (2.0 * M_PI * 17.0);  // the second coil at its peak
  EXPECT_GT((MagnetometerSimulator::trueField(Eigen::Isometry3d::Identity() * Eigen::Translation3d(near_second),
                                              Eigen::Isometry3d::Identity(), world, t) -
             geo.fieldEnu())
                .norm(),
            0.9 * second.peakField(near_second).norm());
  // Without further coils the sum is the one coil's, bit for bit as before they existed.
  world.other_coils.clear();
  const Eigen::Vector3d p(0.5, -1.0, 3.0);
  EXPECT_EQ(world.fieldEnu(p, 0.2), geo.fieldEnu() + first.field(p, 0.2));
}
