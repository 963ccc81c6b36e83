#pragma once
/// @file image_list.h
/// @brief Resolves the `--images` argument of vims_vocab_train: a directory of images or a text
/// file listing image paths.

#include <string>
#include <vector>

namespace vims {

/// A directory gives its image files (extensions png, jpg, jpeg, pgm, ppm, bmp, tif, tiff; case
/// insensitive; not recursive) sorted by name. Any other file is read as a list: one path per
/// line, blank lines and lines starting with '#' skipped, relative paths taken relative to the
/// list's directory. Throws std::runtime_error if the path does not exist, cannot be read or
/// yields no images.
std::vector<std::string> listTrainingImages(const std::string& dir_or_list);

}  // namespace vims
