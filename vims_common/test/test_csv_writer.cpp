// CsvFile / CsvWriter: the header, the rows in order, and a file that cannot be written named.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "vims_common/csv_writer.h"

namespace vims {
namespace {

struct TwiceCsv {
  using Row = int;
  static const char* header() { return "v,twice"; }
  static std::string row(int v) { return std::to_string(v) + "," + std::to_string(2 * v); }
};

TEST(CsvWriter, WritesTheHeaderThenOneLinePerRow) {
  const std::string path = std::string(VIMS_BINARY_DIR) + "/test_csv_writer.csv";
  {
    CsvWriter<TwiceCsv> writer(path);
    EXPECT_EQ(writer.path(), path);
    writer.write(1);
    writer.write(-3);
    writer.flush();
  }
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "v,twice");
  std::getline(in, line);
  EXPECT_EQ(line, "1,2");
  std::getline(in, line);
  EXPECT_EQ(line, "-3,-6");
  EXPECT_FALSE(std::getline(in, line));
  std::remove(path.c_str());
}

TEST(CsvWriter, AFileThatCannotBeCreatedIsNamed) {
  try {
    CsvFile("/nonexistent_dir/x.csv", "a,b");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_dir/x.csv"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vims
