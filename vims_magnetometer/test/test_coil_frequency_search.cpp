// The search for an unknown coil frequency (contract v2: coil_frequency_hz null) and the front
// end that runs the signature extractor once it is found.
#include <gtest/gtest.h>

#include "synthetic_vehicle.h"
#include "vims_common/magnetic_signature.h"
#include "vims_magnetometer/coil_frequency_search.h"
#include "vims_magnetometer/magnetic_front_end.h"

using namespace vims;
using vims_test::Streams;
using vims_test::World;

namespace {

MagnetometerCalibration calibrationFor(const World& world, bool frequency_known) {
  MagnetometerCalibration c;
  c.rate_hz = 1000.0;
  c.noise_std = 5e-9;
  c.coil_frequency_hz = frequency_known ? world.coil_frequency : 0.0;
  c.declination_deg = world.declination_deg;
  return c;
}

/// A pass 2-6 m from the coil, circling it: the coil's amplitude and direction change as the
/// vehicle moves and turns.
Streams pass(const World& world, double duration, double noise, unsigned seed) {
  return vims_test::generate(vims_test::circle(Eigen::Vector3d(0, 0, 3.0), 3.0, 0.3), world, 100.0, duration,
                             Eigen::Matrix3d::Identity(), noise, 0.0, seed);
}

std::vector<MagSample> firstSeconds(const Streams& s, double seconds) {
  std::vector<MagSample> out;
  for (const MagSample& m : s.mag)
    if (m.t - s.mag.front().t < seconds) out.push_back(m);
  return out;
}

TEST(CoilFrequencySearch, FindsTheCoilWithinAHundredthOfAHertzInTenSeconds) {
  for (const double f : {11.0, 13.73, 37.2}) {
    World world;
    world.coil_frequency = f;
    const Streams s = pass(world, 10.5, 5e-9, 3);
    const CoilLine line = findCoilLine(firstSeconds(s, 10.0), 1000.0, CoilSearchOptions());
    ASSERT_TRUE(line.found) << f << " Hz: peak " << line.peak_to_median << "x the median";
    // Measured: |error| <= 1.2e-5 Hz for the three (the refinement's tolerance); the target is 0.02 Hz.
    EXPECT_NEAR(line.frequency_hz, f, 0.005) << f << " Hz";
  }
}

TEST(CoilFrequencySearch, NoiseAloneIsNotTakenForACoil) {
  World world;
  world.coil_moment = 0.0;  // no coil in reach: the geomagnetic field, the vehicle's turns and noise
  const Streams s = pass(world, 10.5, 5e-9, 4);
  const CoilLine line = findCoilLine(firstSeconds(s, 10.0), 1000.0, CoilSearchOptions());
  EXPECT_FALSE(line.found);
  EXPECT_LT(line.peak_to_median, 15.0);  // measured 6.4x; the threshold is 100x
}

using vims_test::Outputs;
using vims_test::run;

TEST(MagneticFrontEnd, AnUnknownFrequencyGivesTheSignaturesOfTheKnownOne) {
  World world;
  world.coil_frequency = 13.73;
  const Streams s = pass(world, 40.0, 5e-9, 5);
  MagneticFrontEnd known(MagnetometerOptions(), calibrationFor(world, true), world.gravity);
  MagneticFrontEnd unknown(MagnetometerOptions(), calibrationFor(world, false), world.gravity);
  EXPECT_DOUBLE_EQ(unknown.coilFrequency(), 0.0);
  const Outputs a = run(known, s);
  const Outputs b = run(unknown, s);
  EXPECT_NEAR(unknown.coilFrequency(), world.coil_frequency, 0.005);
  EXPECT_EQ(unknown.searches(), 1);
  // The buffered first 10 s are processed once the line is found: no window is lost.
  ASSERT_EQ(a.signatures.size(), b.signatures.size());
  ASSERT_EQ(a.geomagnetic.size(), b.geomagnetic.size());
  int valid = 0;
  for (std::size_t i = 0; i < a.signatures.size(); ++i) {
    EXPECT_DOUBLE_EQ(a.signatures[i].t, b.signatures[i].t);
    EXPECT_EQ(a.signatures[i].valid, b.signatures[i].valid);
    if (!a.signatures[i].valid) continue;
    ++valid;
    // A few mHz of frequency error over a 2 s window loses a negligible share of the amplitude.
    const double a_norm = a.signatures[i].amplitude_enu.norm();
    EXPECT_LT(signatureDistance(a.signatures[i].amplitude_enu, b.signatures[i].amplitude_enu), 0.01 * a_norm) << i;
  }
  EXPECT_GT(valid, 50);
}

TEST(MagneticFrontEnd, WithoutACoilInReachItKeepsSearchingAndOutputsNothing) {
  World world;
  world.coil_moment = 0.0;
  const Streams s = pass(world, 30.0, 5e-9, 6);
  MagneticFrontEnd front_end(MagnetometerOptions(), calibrationFor(world, false), world.gravity);
  const Outputs out = run(front_end, s);
  EXPECT_TRUE(out.signatures.empty());
  EXPECT_TRUE(out.geomagnetic.empty());
  EXPECT_DOUBLE_EQ(front_end.coilFrequency(), 0.0);
  EXPECT_GE(front_end.searches(), 4);  // every 5 s after the first 10 s
  // Samples of failed searches are counted; the last (at most 10 s) are still buffered.
  EXPECT_LT(front_end.stats().mag_samples, static_cast<long>(s.mag.size()) - 4000);
  EXPECT_GT(front_end.stats().mag_samples, static_cast<long>(s.mag.size()) - 10001);
}

TEST(MagneticFrontEnd, SeveralCoilsGiveOneSignaturePerCoil) {
  // Coil 0 (11 Hz) at the centre of the circle, coil 1 (17 Hz) 4 m to the east: the magnetometer
  // measures the sum. A front end told of both must give each coil's field, and coil 0's
  // signatures as a front end of one coil gives them without coil 1.
  World a;
  World b;
  b.coil_w = Eigen::Vector3d(4.0, 0.0, 0.0);
  b.coil_frequency = 17.0;
  b.coil_phase = 1.1;
  World b_off = b;
  b_off.coil_moment = 0.0;
  const Streams alone = pass(a, 40.0, 5e-9, 7);
  const Streams with_b = pass(b, 40.0, 0.0, 7);
  const Streams without_b = pass(b_off, 40.0, 0.0, 7);
  Streams both = alone;
  for (std::size_t k = 0; k < both.mag.size(); ++k) both.mag[k].field += with_b.mag[k].field - without_b.mag[k].field;

  MagnetometerCalibration two = calibrationFor(a, true);
  two.other_coil_frequencies_hz = {b.coil_frequency};
  MagneticFrontEnd front_end(MagnetometerOptions(), two, a.gravity);
  EXPECT_EQ(front_end.coils(), 2);
  MagneticFrontEnd one(MagnetometerOptions(), calibrationFor(a, true), a.gravity);
  const Outputs out = run(front_end, both);
  const Outputs reference = run(one, alone);
  EXPECT_EQ(out.geomagnetic.size(), reference.geomagnetic.size());

  const vims_test::Motion motion = vims_test::circle(Eigen::Vector3d(0, 0, 3.0), 3.0, 0.3);
  std::vector<SignatureWindow> coil0, coil1;
  for (const SignatureWindow& w : out.signatures) (w.coil == 0 ? coil0 : coil1).push_back(w);
  ASSERT_EQ(coil0.size(), reference.signatures.size());
  ASSERT_EQ(coil1.size(), coil0.size());
  int valid0 = 0, valid1 = 0;
  for (std::size_t i = 0; i < coil0.size(); ++i) {
    EXPECT_DOUBLE_EQ(coil0[i].t, reference.signatures[i].t);
    EXPECT_EQ(coil1[i].coil, 1);
    EXPECT_NEAR(coil1[i].frequency_hz, b.coil_frequency, 0.5);
    if (coil0[i].valid && reference.signatures[i].valid) {
      ++valid0;
      const double norm = reference.signatures[i].amplitude_enu.norm();
      EXPECT_LT(signatureDistance(coil0[i].amplitude_enu, reference.signatures[i].amplitude_enu), 2e-4 * norm)
          << i;  // measured <= 0.8e-4
    }
    if (coil1[i].valid) {
      ++valid1;
      const Eigen::Vector3d truth = canonicalSignature(b.coilPeak(motion.p_w_b(coil1[i].t - 100.0)));
      EXPECT_LT(signatureDistance(coil1[i].amplitude_enu, truth), 0.015 * truth.norm()) << i;  // measured <= 0.76 %
    }
  }
  EXPECT_GE(valid0, 85);  // measured 93 of 93 windows, both coils
  EXPECT_GE(valid1, 85);
}

}  // namespace
