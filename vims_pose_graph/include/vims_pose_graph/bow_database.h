#pragma once
/// @file bow_database.h
/// @brief An image database over a BinaryVocabulary: an inverted index (word -> images) for
/// fast top-N queries over all images, direct scoring for queries restricted to a candidate
/// subset (the hierarchical loop closer searches only the visual submaps clustered under the
/// magnetic candidates), and the per-image direct index for feature matching.
///
/// Not thread-safe for concurrent add() and query(); the owner serialises them (queries alone
/// may run concurrently: they are const).

#include <memory>
#include <vector>

#include "vims_pose_graph/vocabulary.h"

namespace vims {

/// Database-local id of an image, assigned 0, 1, 2, ... in the order of add().
using ImageId = uint32_t;

struct BowQueryResult {
  ImageId image = 0;
  double score = 0.0;  ///< bowScoreL1 with the query, in [0, 1]
};

class BowDatabase {
 public:
  /// `direct_index_depth` is the tree depth of the direct index (see BinaryVocabulary::transform);
  /// values above the vocabulary's depth are clamped to it. Throws std::invalid_argument for a
  /// null or empty vocabulary or a depth < 1.
  BowDatabase(std::shared_ptr<const BinaryVocabulary> vocabulary, int direct_index_depth);

  /// Transforms the descriptors of one image and stores it. Returns its id.
  ImageId add(const std::vector<BinaryDescriptor>& descriptors);
  /// Stores an already transformed image (BoW vector from the same vocabulary; it is sorted,
  /// merged and L1-normalised on the way in). Throws std::invalid_argument for a word id
  /// outside the vocabulary.
  ImageId add(const BowVector& bow, FeatureVector direct_index = {});

  size_t size() const { return images_.size(); }
  const BinaryVocabulary& vocabulary() const { return *vocabulary_; }
  int directIndexDepth() const { return direct_index_depth_; }
  /// Throw std::out_of_range for an unknown id.
  const BowVector& bowVector(ImageId id) const;
  const FeatureVector& featureVector(ImageId id) const;

  /// The `max_results` best images over the whole database, best first (score descending, ties
  /// by ascending id). Images with no word in common with the query score 0 and are omitted.
  std::vector<BowQueryResult> query(const BowVector& query, size_t max_results) const;
  /// Same, restricted to `candidates` (unknown ids and duplicates are ignored). Scores are the
  /// ones query() gives; the cost is linear in the candidates' vector sizes, not the database's.
  std::vector<BowQueryResult> queryAmong(const BowVector& query, const std::vector<ImageId>& candidates,
                                         size_t max_results) const;

 private:
  struct Image {
    BowVector bow;
    FeatureVector direct;
  };
  struct Posting {
    ImageId image;
    double weight;  ///< the word's weight in that image's normalised vector
  };

  static std::vector<BowQueryResult> selectBest(std::vector<BowQueryResult> results, size_t max_results);

  std::shared_ptr<const BinaryVocabulary> vocabulary_;
  int direct_index_depth_;
  std::vector<Image> images_;
  std::vector<std::vector<Posting>> inverted_;  ///< word id -> images containing it
};

}  // namespace vims
