#pragma once
/// @file coil_frequency_search.h
/// @brief Finds the seabed coil's frequency in raw magnetometer data, for sequences that leave it
/// open (contract v2: magnetometer.coil_frequency_hz null or absent).
///
/// The coil is the one strong narrow line in the magnetometer's spectrum: the geomagnetic field
/// sits at 0 Hz and moves only as the vehicle turns (below ~1 Hz), the noise is broadband. So:
///  1. Each axis minus its mean, Hann-weighted (sidelobes fall as 1/f^3, so the large slow
///     geomagnetic part does not leak into the band), zero-padded to twice its length and
///     transformed (cv::dft); the power of the three axes is summed, so the line is found
///     whatever the vehicle's heading does to its direction.
///  2. Among the local maxima inside [min_frequency_hz, max_fraction_of_nyquist * rate_hz / 2],
///     the one standing highest above the median of the spectrum within 1 Hz of it (its own main
///     lobe left out) is the coil, when that ratio reaches min_peak_to_median. The local median
///     follows a coloured floor (the leakage of the slow geomagnetic part near the low edge), so
///     only a narrow line counts.
///  3. The peak is refined to the maximum of the Hann-weighted DTFT power evaluated at the
///     samples' own stamps (golden-section search within one bin each side), so neither the
///     bin grid nor a clock slightly off rate_hz limits the estimate.

#include <vector>

#include "vims_common/sensor_data.h"
#include "vims_magnetometer/magnetometer_options.h"

namespace vims {

struct CoilLine {
  bool found = false;           ///< the strongest line stands out enough to be the coil
  double frequency_hz = 0.0;    ///< the strongest line (refined when found)
  double peak_to_median = 0.0;  ///< its power over the median power within 1 Hz of it
};

/// Searches `samples` (stamps increasing, nominally `rate_hz`); at least 64 samples.
CoilLine findCoilLine(const std::vector<MagSample>& samples, double rate_hz, const CoilSearchOptions& options);

}  // namespace vims
