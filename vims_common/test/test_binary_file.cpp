// readFileBytes and MappedFile: the whole file, byte for byte (also an empty one), and a clear error naming a
// missing file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "vims_common/binary_file.h"

TEST(BinaryFile, ReadsEveryByteAndNamesAMissingFile) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("vims_binary_file_" + std::to_string(::getpid()));
  std::vector<uint8_t> written(300000);
  for (size_t i = 0; i < written.size(); ++i) written[i] = static_cast<uint8_t>((i * 2654435761u) >> 13);
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(written.data()), static_cast<std::streamsize>(written.size()));
  }
  EXPECT_EQ(vims::readFileBytes(path.string()), written);
  std::ofstream(path, std::ios::binary | std::ios::trunc).close();
  EXPECT_TRUE(vims::readFileBytes(path.string()).empty());
  std::filesystem::remove(path);
  try {
    vims::readFileBytes(path.string());
    ADD_FAILURE() << "no error for a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + "': cannot be opened"), std::string::npos) << e.what();
  }
}

TEST(MappedFile, MapsEveryByteKeepsThemAfterARenameAndNamesAMissingFile) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("vims_mapped_file_" + std::to_string(::getpid()));
  std::vector<uint8_t> written(300000);
  for (size_t i = 0; i < written.size(); ++i) written[i] = static_cast<uint8_t>((i * 2654435761u) >> 11);
  auto write = [&](const std::filesystem::path& p, const std::vector<uint8_t>& bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  };
  write(path, written);
  {
    const vims::MappedFile mapped(path.string());
    ASSERT_EQ(mapped.size(), written.size());
    EXPECT_TRUE(std::equal(written.begin(), written.end(), mapped.data()));
    // Another file renamed over it (as a map save does) leaves the mapped contents as they were.
    const std::filesystem::path other = path.string() + ".tmp";
    write(other, std::vector<uint8_t>(1000, 7));
    std::filesystem::rename(other, path);
    EXPECT_TRUE(std::equal(written.begin(), written.end(), mapped.data()));
  }
  write(path, {});
  {
    const vims::MappedFile empty(path.string());
    EXPECT_EQ(empty.size(), 0u);
    EXPECT_EQ(empty.data(), nullptr);
  }
  std::filesystem::remove(path);
  try {
    const vims::MappedFile missing(path.string());
    ADD_FAILURE() << "no error for a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string() + "': cannot be opened"), std::string::npos) << e.what();
  }
}
