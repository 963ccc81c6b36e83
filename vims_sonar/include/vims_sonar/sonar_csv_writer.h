#pragma once
/// @file sonar_csv_writer.h
/// @brief Writes the sonar filter's verdicts as `sonar_filtered.csv` (columns documented in
/// docs/frontends.md): header row `t,raw_range,filtered_range,accepted,status`, one row per input
/// sample, t in seconds (bag clock), ranges in metres, accepted 0/1, status as sonarStatusName().
/// A non-finite raw range is written `inf`/`nan`; a filtered range without estimate `nan`.

#include <fstream>
#include <string>

#include "vims_sonar/sonar_altitude_filter.h"

namespace vims {

class SonarCsvWriter {
 public:
  /// Creates (truncates) the file and writes the header. Throws std::runtime_error if it cannot.
  explicit SonarCsvWriter(const std::string& path);
  /// Appends one row. Throws std::runtime_error on an I/O error.
  void write(const SonarFilterResult& result);
  void flush();
  const std::string& path() const { return path_; }
  static const char* header();

 private:
  std::string path_;
  std::ofstream out_;
};

}  // namespace vims
