#include "vims_common/csv_writer.h"

#include <stdexcept>

namespace vims {

CsvFile::CsvFile(const std::string& path, const std::string& header) : path_(path), out_(path, std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot write '" + path + "'");
  writeRow(header);
}

void CsvFile::writeRow(const std::string& row) {
  out_ << row << '\n';
  if (!out_) throw std::runtime_error("failed while writing '" + path_ + "'");
}

void CsvFile::flush() {
  out_.flush();
  if (!out_) throw std::runtime_error("failed while writing '" + path_ + "'");
}

}  // namespace vims
