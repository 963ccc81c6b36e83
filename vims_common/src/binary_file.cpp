#include "vims_common/binary_file.h"

#include <fstream>
#include <stdexcept>

namespace vims {

std::vector<uint8_t> readFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw std::runtime_error("'" + path + "': cannot be opened");
  const std::streamoff size = in.tellg();
  if (size < 0) throw std::runtime_error("'" + path + "': cannot tell its size");
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.seekg(0);
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size)))
    throw std::runtime_error("'" + path + "': read error");
  return bytes;
}

}  // namespace vims
