#pragma once
/// @file vocabulary.h
/// @brief A hierarchical k-medians vocabulary tree for 256-bit binary descriptors with TF-IDF
/// weighting and L1 scoring (the bag-of-words model of Nister & Stewenius 2006 and Galvez-Lopez &
/// Tardos 2012, written for VIMS). The algorithm and the file format are in docs/vocabulary.md.
///
/// A vocabulary is immutable after training or loading, so one instance may be shared (const)
/// between threads: every query method is const and touches no mutable state.

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_common/log.h"
#include "vims_pose_graph/binary_descriptor.h"

namespace vims {

template <typename Options>
class OptionTable;

using WordId = uint32_t;
/// Index of a node of the vocabulary tree (0 = root), used as the key of the direct index.
using VocabularyNodeId = uint32_t;

struct BowEntry {
  WordId word = 0;
  double weight = 0.0;
};

/// A sparse bag-of-words vector: entries sorted by word id, each word once, weights > 0.
/// Vectors produced by BinaryVocabulary::transform are L1-normalised (sum of weights 1); an
/// image without features (or whose words all have zero IDF) gives an empty vector.
struct BowVector {
  std::vector<BowEntry> entries;

  bool empty() const { return entries.empty(); }
  size_t size() const { return entries.size(); }
  /// Weight of `word` (0 when absent); binary search.
  double weight(WordId word) const;
  double l1Norm() const;
};

/// The direct index of one image: for each tree node at the chosen depth, the indices (into the
/// image's descriptor list) of the features whose descent passed through that node. Loop
/// verification matches only features sharing a node, which prunes the 2-NN search.
using FeatureVector = std::map<VocabularyNodeId, std::vector<uint32_t>>;

/// L1 similarity s(v1, v2) = 1 - 0.5 * | v1/|v1|_1 - v2/|v2|_1 |_1, in [0, 1] (1 = identical
/// word distribution). Inputs need not be normalised; an empty vector scores 0.
double bowScoreL1(const BowVector& v1, const BowVector& v2);

/// Thrown when a vocabulary file cannot be read, is truncated, corrupt or of another version;
/// what() names the file and the problem.
class VocabularyFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Options of vocabulary training (`vims_vocab_train`, or a `vocabulary:` YAML mapping).
struct VocabularyTrainingOptions {
  int branching = 8;                    ///< k: children per node (k^L words at most)
  int levels = 4;                       ///< L: depth of the tree below the root
  uint64_t seed = 1;                    ///< seeds k-means++; the same seed and input give the same tree
  int max_iterations = 20;              ///< k-medians iterations per node (stops earlier when assignments settle)
  std::string descriptor_type = "orb";  ///< label stored in the file ("orb" or "brief")

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<VocabularyTrainingOptions>& optionTable();

  /// Keys: branching, levels, seed, max_iterations, descriptor_type. Unknown keys and
  /// out-of-range values throw ConfigError naming the key.
  static VocabularyTrainingOptions fromReader(const ConfigReader& reader);
  /// Throws std::invalid_argument naming the first out-of-range field (for options built in code).
  void validate() const;
  std::string toYaml() const;
};

class BinaryVocabulary {
 public:
  /// Version of the binary file format written by save().
  static constexpr uint32_t kFileVersion = 1;

  /// An empty vocabulary (no words); transform() on it throws std::logic_error.
  BinaryVocabulary() = default;

  /// Trains the tree by hierarchical k-medians on the descriptors of `images` (one vector per
  /// training image), then sets each word's IDF weight log(N / n_w) from the N training images
  /// (n_w = images in which word w occurs). Throws std::invalid_argument for invalid options or
  /// when there are no descriptors at all. Deterministic for a given seed and input order.
  static BinaryVocabulary train(const std::vector<std::vector<BinaryDescriptor>>& images,
                                const VocabularyTrainingOptions& options, const LoggerPtr& logger = nullptr);

  /// Binary save / load (format in docs/vocabulary.md). save() throws std::runtime_error on an
  /// I/O failure; load() throws VocabularyFileError (file missing, truncated, bad magic, version,
  /// checksum or inconsistent tree).
  void save(const std::string& path) const;
  static BinaryVocabulary load(const std::string& path);
  std::vector<uint8_t> serialize() const;
  static BinaryVocabulary deserialize(const std::vector<uint8_t>& bytes, const std::string& source_name);

  bool empty() const { return words_.empty(); }
  int branching() const { return branching_; }
  int levels() const { return levels_; }
  size_t numNodes() const { return nodes_.size(); }
  size_t numWords() const { return words_.size(); }
  const std::string& descriptorType() const { return descriptor_type_; }
  /// Number of training images the IDF weights were computed from.
  uint64_t numTrainingImages() const { return num_training_images_; }

  /// The word of one descriptor: greedy descent choosing the child with the smallest Hamming
  /// distance at each level (ties: the first child).
  WordId wordOf(const BinaryDescriptor& descriptor) const;
  double wordWeight(WordId word) const;
  /// Tree node of a word (its leaf).
  VocabularyNodeId wordNode(WordId word) const;

  /// TF-IDF bag of words of one image, L1-normalised: each feature adds its word's IDF weight
  /// (tf is the count divided by the number of features, which the normalisation absorbs).
  BowVector transform(const std::vector<BinaryDescriptor>& descriptors) const;
  /// Same, plus the direct index at tree depth `direct_index_depth` (1 = children of the root,
  /// levels() = the words themselves; a word that is a leaf above that depth uses its own leaf).
  /// Throws std::invalid_argument for a depth outside [1, levels()].
  BowVector transform(const std::vector<BinaryDescriptor>& descriptors, FeatureVector* direct_index,
                      int direct_index_depth) const;

 private:
  static constexpr uint32_t kNoWord = 0xFFFFFFFFu;
  static constexpr uint32_t kNoParent = 0xFFFFFFFFu;

  struct Node {
    BinaryDescriptor descriptor;  ///< cluster median (unused for the root)
    uint32_t parent = kNoParent;
    uint32_t first_child = 0;  ///< children are stored contiguously
    uint32_t num_children = 0;
    uint32_t depth = 0;       ///< 0 = root
    uint32_t word = kNoWord;  ///< word id when the node is a leaf
  };

  /// Descends from the root; fills the node at `record_depth` (if > 0) into *recorded.
  uint32_t descend(const BinaryDescriptor& descriptor, int record_depth, uint32_t* recorded) const;
  void computeIdf(const std::vector<std::vector<BinaryDescriptor>>& images);
  /// Rebuilds first_child / num_children / depth / words_ from the parents; throws
  /// VocabularyFileError naming `source` when the tree is inconsistent.
  void linkTree(const std::string& source);

  int branching_ = 0;
  int levels_ = 0;
  std::string descriptor_type_;
  uint64_t num_training_images_ = 0;
  std::vector<Node> nodes_;
  std::vector<uint32_t> words_;  ///< word id -> leaf node
  std::vector<double> weights_;  ///< word id -> IDF weight
};

}  // namespace vims
