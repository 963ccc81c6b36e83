#include "vims_sonar/sonar_csv_writer.h"

#include <cmath>
#include <cstdio>

namespace vims {
namespace {
/// Fixed-point text with explicit spellings for non-finite values (iostreams vary: "-nan").
std::string number(double v, int decimals) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}
}  // namespace

const char* SonarCsv::header() { return "t,raw_range,filtered_range,accepted,status"; }

std::string SonarCsv::row(const SonarFilterResult& r) {
  // 1 us stamps and 0.1 mm ranges are below every sensor's resolution.
  return number(r.t, 6) + ',' + number(r.raw, 4) + ',' + number(r.has_estimate ? r.filtered : NAN, 4) + ',' +
         (r.accepted ? '1' : '0') + ',' + sonarStatusName(r.status);
}

}  // namespace vims
