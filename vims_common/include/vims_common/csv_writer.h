#pragma once
/// @file csv_writer.h
/// @brief The CSV outputs of a run (sonar_filtered.csv, mag_signatures.csv, loops.csv,
/// seabed.csv): a file created with its header row, one row per write. Every write and the flush
/// are checked, so a full disk or a vanished directory is an exception naming the file rather
/// than a silently short table that vims_eval would then read as the whole run.

#include <fstream>
#include <string>

namespace vims {

/// The file: created (truncated) with `header`; each row written as given plus a newline.
class CsvFile {
 public:
  /// Throws std::runtime_error naming `path` if it cannot be created.
  CsvFile(const std::string& path, const std::string& header);
  /// Appends `row` (no trailing newline). Throws std::runtime_error on an I/O error.
  void writeRow(const std::string& row);
  /// Throws std::runtime_error on an I/O error.
  void flush();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ofstream out_;
};

/// A CsvFile for one table format: `Format` names its row type (`Format::Row`), its header row
/// (`Format::header()`) and how a row is written (`Format::row(const Row&)`, one line without the
/// newline).
template <typename Format>
class CsvWriter {
 public:
  explicit CsvWriter(const std::string& path) : file_(path, Format::header()) {}
  void write(const typename Format::Row& row) { file_.writeRow(Format::row(row)); }
  void flush() { file_.flush(); }
  const std::string& path() const { return file_.path(); }

 private:
  CsvFile file_;
};

}  // namespace vims
