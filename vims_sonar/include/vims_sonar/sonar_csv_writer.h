#pragma once
/// @file sonar_csv_writer.h
/// @brief Writes the sonar filter's verdicts as `sonar_filtered.csv` (columns documented in
/// docs/frontends.md): header row `t,raw_range,filtered_range,accepted,status`, one row per input
/// sample, t in seconds (bag clock), ranges in metres, accepted 0/1, status as sonarStatusName().
/// A non-finite raw range is written `inf`/`nan`; a filtered range without estimate `nan`.

#include <string>

#include "vims_common/csv_writer.h"
#include "vims_sonar/sonar_altitude_filter.h"

namespace vims {

/// The format of `sonar_filtered.csv` (CsvWriter).
struct SonarCsv {
  using Row = SonarFilterResult;
  static const char* header();
  static std::string row(const SonarFilterResult& result);
};
using SonarCsvWriter = CsvWriter<SonarCsv>;

}  // namespace vims
