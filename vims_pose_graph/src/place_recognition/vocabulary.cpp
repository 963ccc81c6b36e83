#include "vims_pose_graph/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "vims_common/binary_file.h"
#include "vims_common/fnv1a.h"
#include "vims_common/option_table.h"

namespace vims {

// ---------------------------------------------------------------------------------------------
// BowVector and scoring
// ---------------------------------------------------------------------------------------------

double BowVector::weight(WordId word) const {
  auto it =
      std::lower_bound(entries.begin(), entries.end(), word, [](const BowEntry& e, WordId w) { return e.word < w; });
  return (it != entries.end() && it->word == word) ? it->weight : 0.0;
}

double BowVector::l1Norm() const {
  double sum = 0.0;
  for (const BowEntry& e : entries) sum += std::abs(e.weight);
  return sum;
}

double bowScoreL1(const BowVector& v1, const BowVector& v2) {
  const double n1 = v1.l1Norm();
  const double n2 = v2.l1Norm();
  if (n1 <= 0.0 || n2 <= 0.0) return 0.0;
  // Merge walk over the two sorted vectors: |a - b|_1 = sum over common words |a_i - b_i| plus
  // the weights of the words only one of them has.
  double diff = 0.0;
  auto a = v1.entries.begin();
  auto b = v2.entries.begin();
  while (a != v1.entries.end() || b != v2.entries.end()) {
    if (b == v2.entries.end() || (a != v1.entries.end() && a->word < b->word)) {
      diff += std::abs(a->weight / n1);
      ++a;
    } else if (a == v1.entries.end() || b->word < a->word) {
      diff += std::abs(b->weight / n2);
      ++b;
    } else {
      diff += std::abs(a->weight / n1 - b->weight / n2);
      ++a;
      ++b;
    }
  }
  // Rounding can push the result a hair outside [0, 1].
  return std::clamp(1.0 - 0.5 * diff, 0.0, 1.0);
}

// ---------------------------------------------------------------------------------------------
// Options
// ---------------------------------------------------------------------------------------------

const OptionTable<VocabularyTrainingOptions>& VocabularyTrainingOptions::optionTable() {
  using O = VocabularyTrainingOptions;
  static const auto table = OptionTable<O>()
                                .integer("branching", &O::branching, Bounds::closed(2, 64))
                                .integer("levels", &O::levels, Bounds::closed(1, 8))
                                .integer<uint64_t>("seed", &O::seed, Bounds::nonNegative())
                                .integer("max_iterations", &O::max_iterations, Bounds::closed(1, 1000))
                                .text("descriptor_type", &O::descriptor_type, false)
                                .rule([](const O& o) {
                                  return violationIf(std::pow(static_cast<double>(o.branching), o.levels) > 2.0e7,
                                                     "levels", "branching^levels exceeds 2e7 words");
                                });
  return table;
}

void VocabularyTrainingOptions::validate() const {
  if (const auto v = optionTable().firstViolation(*this)) {
    throw std::invalid_argument("vocabulary " + v->key + " " + v->message);
  }
  if (descriptor_type.size() > 32) throw std::invalid_argument("vocabulary descriptor_type must have 1..32 characters");
}

VocabularyTrainingOptions VocabularyTrainingOptions::fromReader(const ConfigReader& reader) {
  const auto o = readOptions<VocabularyTrainingOptions>(reader);
  if (o.descriptor_type != "orb" && o.descriptor_type != "brief")
    throw reader.error("descriptor_type", "must be 'orb' or 'brief', got '" + o.descriptor_type + "'");
  return o;
}

std::string VocabularyTrainingOptions::toYaml() const { return optionTable().toYaml(*this); }

// ---------------------------------------------------------------------------------------------
// Training: hierarchical k-medians
// ---------------------------------------------------------------------------------------------

namespace {

/// Uniform draws from std::mt19937_64, whose output sequence the C++ standard fixes (unlike the
/// std::*_distribution classes), so a seed gives the same vocabulary with any standard library.
class DeterministicRng {
 public:
  explicit DeterministicRng(uint64_t seed) : engine_(seed) {}
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  /// Uniform index in [0, n); the modulo bias is below n / 2^64 and irrelevant here.
  size_t index(size_t n) { return static_cast<size_t>(engine_() % n); }

 private:
  std::mt19937_64 engine_;
};

struct Cluster {
  BinaryDescriptor center;
  std::vector<uint32_t> members;  ///< indices into the flat descriptor list
};

/// Nearest center (smallest Hamming distance, ties to the lowest index).
VIMS_POPCOUNT_DISPATCH size_t nearestCenter(const BinaryDescriptor& d, const std::vector<BinaryDescriptor>& centers) {
  size_t best = 0;
  int best_dist = std::numeric_limits<int>::max();
  for (size_t c = 0; c < centers.size(); ++c) {
    const int dist = hammingDistance(d, centers[c]);
    if (dist < best_dist) {
      best_dist = dist;
      best = c;
    }
  }
  return best;
}

/// k-medians in Hamming space of the descriptors `members` (indices into `all`): k-means++
/// seeding with squared Hamming distances, then Lloyd iterations with bitwise-majority medians.
/// Returns at most k non-empty clusters; fewer when the members hold fewer distinct values.
std::vector<Cluster> kMedians(const std::vector<BinaryDescriptor>& all, const std::vector<uint32_t>& members, int k,
                              int max_iterations, DeterministicRng& rng) {
  const size_t n = members.size();
  std::vector<BinaryDescriptor> centers;
  // Seeding. Each new center is a member drawn with probability proportional to its squared
  // distance to the nearest chosen center, which spreads the seeds (Arthur & Vassilvitskii 2007);
  // members equal to a chosen center have weight 0, so duplicates never become two centers.
  centers.push_back(all[members[rng.index(n)]]);
  std::vector<double> dist2(n);
  for (size_t i = 0; i < n; ++i) {
    const double d = hammingDistance(all[members[i]], centers[0]);
    dist2[i] = d * d;
  }
  while (static_cast<int>(centers.size()) < k) {
    double total = 0.0;
    for (double d : dist2) total += d;
    if (total <= 0.0) break;  // every member equals one of the centers
    const double target = rng.uniform() * total;
    double cumulative = 0.0;
    size_t pick = n - 1;
    for (size_t i = 0; i < n; ++i) {
      cumulative += dist2[i];
      if (cumulative > target && dist2[i] > 0.0) {
        pick = i;
        break;
      }
    }
    if (dist2[pick] <= 0.0) {
      // Rounding left `target` at the very end of the cumulative sum: take the last member that
      // is not yet a center.
      for (size_t i = n; i-- > 0;) {
        if (dist2[i] > 0.0) {
          pick = i;
          break;
        }
      }
    }
    centers.push_back(all[members[pick]]);
    for (size_t i = 0; i < n; ++i) {
      const double d = hammingDistance(all[members[i]], centers.back());
      dist2[i] = std::min(dist2[i], d * d);
    }
  }

  std::vector<uint32_t> assignment(n, 0);
  auto assign = [&]() {
    bool changed = false;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t c = static_cast<uint32_t>(nearestCenter(all[members[i]], centers));
      if (c != assignment[i]) changed = true;
      assignment[i] = c;
    }
    return changed;
  };
  assign();
  for (int it = 0; it < max_iterations; ++it) {
    std::vector<std::vector<uint32_t>> groups(centers.size());
    for (size_t i = 0; i < n; ++i) groups[assignment[i]].push_back(members[i]);
    std::vector<BinaryDescriptor> new_centers;
    bool dropped = false;
    for (const auto& g : groups) {
      if (g.empty()) {
        dropped = true;  // a median moved away from all its members: drop the cluster
        continue;
      }
      new_centers.push_back(bitwiseMajority(all, g));
    }
    centers.swap(new_centers);
    // After a drop the indices shift, so the assignment counts as changed.
    const bool changed = assign() || dropped;
    if (!changed) break;
  }
  // The final assignment is with respect to the final centers, which is what the greedy descent
  // of wordOf() reproduces.
  std::vector<Cluster> clusters(centers.size());
  for (size_t c = 0; c < centers.size(); ++c) clusters[c].center = centers[c];
  for (size_t i = 0; i < n; ++i) clusters[assignment[i]].members.push_back(members[i]);
  clusters.erase(std::remove_if(clusters.begin(), clusters.end(), [](const Cluster& c) { return c.members.empty(); }),
                 clusters.end());
  return clusters;
}

}  // namespace

BinaryVocabulary BinaryVocabulary::train(const std::vector<std::vector<BinaryDescriptor>>& images,
                                         const VocabularyTrainingOptions& options, const LoggerPtr& logger) {
  options.validate();
  std::vector<BinaryDescriptor> all;
  size_t images_with_features = 0;
  for (const auto& img : images) {
    all.insert(all.end(), img.begin(), img.end());
    if (!img.empty()) ++images_with_features;
  }
  if (all.empty()) throw std::invalid_argument("BinaryVocabulary::train: no descriptors to train on");
  if (images_with_features < 2)
    throw std::invalid_argument("BinaryVocabulary::train: IDF weights need at least two images with features");
  if (all.size() >= kNoWord) throw std::invalid_argument("BinaryVocabulary::train: too many descriptors");

  BinaryVocabulary voc;
  voc.branching_ = options.branching;
  voc.levels_ = options.levels;
  voc.descriptor_type_ = options.descriptor_type;
  voc.nodes_.emplace_back();  // root

  DeterministicRng rng(options.seed);
  struct Pending {
    uint32_t node;
    std::vector<uint32_t> members;
  };
  // Breadth-first construction: the children of a node are appended together, so they are
  // contiguous and every parent precedes its children (the file format relies on both).
  std::deque<Pending> queue;
  {
    Pending root{0, std::vector<uint32_t>(all.size())};
    for (size_t i = 0; i < all.size(); ++i) root.members[i] = static_cast<uint32_t>(i);
    queue.push_back(std::move(root));
  }
  while (!queue.empty()) {
    Pending p = std::move(queue.front());
    queue.pop_front();
    const uint32_t depth = voc.nodes_[p.node].depth;
    if (static_cast<int>(depth) >= options.levels) continue;  // a word at full depth
    std::vector<Cluster> clusters = kMedians(all, p.members, options.branching, options.max_iterations, rng);
    // One cluster means all members are equal (or collapsed into one median): splitting it
    // further cannot separate anything, so the node stays a leaf above full depth.
    if (clusters.size() <= 1) continue;
    const uint32_t first = static_cast<uint32_t>(voc.nodes_.size());
    voc.nodes_[p.node].first_child = first;
    voc.nodes_[p.node].num_children = static_cast<uint32_t>(clusters.size());
    for (Cluster& c : clusters) {
      Node child;
      child.descriptor = c.center;
      child.parent = p.node;
      child.depth = depth + 1;
      const uint32_t id = static_cast<uint32_t>(voc.nodes_.size());
      voc.nodes_.push_back(child);
      queue.push_back(Pending{id, std::move(c.members)});
    }
  }
  // Words are the leaves, numbered in breadth-first order.
  for (uint32_t i = 0; i < voc.nodes_.size(); ++i) {
    if (voc.nodes_[i].num_children == 0) {
      voc.nodes_[i].word = static_cast<uint32_t>(voc.words_.size());
      voc.words_.push_back(i);
    }
  }
  voc.computeIdf(images);
  if (logger) {
    logger->info("vocabulary",
                 VIMS_STR("trained k=" << options.branching << " L=" << options.levels << ": " << voc.words_.size()
                                       << " words, " << voc.nodes_.size() << " nodes from " << all.size()
                                       << " descriptors of " << images.size() << " images"));
  }
  return voc;
}

void BinaryVocabulary::computeIdf(const std::vector<std::vector<BinaryDescriptor>>& images) {
  // n_w = number of training images in which word w occurs at least once.
  std::vector<uint64_t> images_with_word(words_.size(), 0);
  std::vector<int64_t> last_image(words_.size(), -1);
  for (size_t i = 0; i < images.size(); ++i) {
    for (const BinaryDescriptor& d : images[i]) {
      const WordId w = wordOf(d);
      if (last_image[w] != static_cast<int64_t>(i)) {
        last_image[w] = static_cast<int64_t>(i);
        ++images_with_word[w];
      }
    }
  }
  num_training_images_ = images.size();
  const double n = static_cast<double>(images.size());
  weights_.resize(words_.size());
  for (size_t w = 0; w < words_.size(); ++w) {
    // A word no training descriptor descends to (possible when a median moved) is treated as
    // seen in one image: rare, hence informative, rather than silently ignored.
    const double n_w = std::max<double>(1.0, static_cast<double>(images_with_word[w]));
    weights_[w] = std::log(n / n_w);
  }
}

// ---------------------------------------------------------------------------------------------
// Queries
// ---------------------------------------------------------------------------------------------

VIMS_POPCOUNT_DISPATCH uint32_t BinaryVocabulary::descend(const BinaryDescriptor& descriptor, int record_depth,
                                                          uint32_t* recorded) const {
  uint32_t node = 0;
  if (recorded) *recorded = 0;
  while (nodes_[node].num_children > 0) {
    const Node& n = nodes_[node];
    uint32_t best = n.first_child;
    int best_dist = std::numeric_limits<int>::max();
    for (uint32_t c = n.first_child; c < n.first_child + n.num_children; ++c) {
      const int dist = hammingDistance(descriptor, nodes_[c].descriptor);
      if (dist < best_dist) {
        best_dist = dist;
        best = c;
      }
    }
    node = best;
    if (recorded && static_cast<int>(nodes_[node].depth) <= record_depth) *recorded = node;
  }
  return node;
}

WordId BinaryVocabulary::wordOf(const BinaryDescriptor& descriptor) const {
  if (empty()) throw std::logic_error("BinaryVocabulary: the vocabulary is empty");
  return nodes_[descend(descriptor, 0, nullptr)].word;
}

double BinaryVocabulary::wordWeight(WordId word) const { return weights_.at(word); }

VocabularyNodeId BinaryVocabulary::wordNode(WordId word) const { return words_.at(word); }

BowVector BinaryVocabulary::transform(const std::vector<BinaryDescriptor>& descriptors) const {
  return transform(descriptors, nullptr, levels_);
}

BowVector BinaryVocabulary::transform(const std::vector<BinaryDescriptor>& descriptors, FeatureVector* direct_index,
                                      int direct_index_depth) const {
  if (empty()) throw std::logic_error("BinaryVocabulary: the vocabulary is empty");
  if (direct_index_depth < 1 || direct_index_depth > levels_)
    throw std::invalid_argument("BinaryVocabulary::transform: direct_index_depth must be in [1, " +
                                std::to_string(levels_) + "], got " + std::to_string(direct_index_depth));
  if (direct_index) direct_index->clear();
  std::vector<BowEntry> raw;
  raw.reserve(descriptors.size());
  for (size_t i = 0; i < descriptors.size(); ++i) {
    uint32_t recorded = 0;
    const uint32_t leaf = descend(descriptors[i], direct_index_depth, direct_index ? &recorded : nullptr);
    const WordId w = nodes_[leaf].word;
    if (direct_index) (*direct_index)[recorded].push_back(static_cast<uint32_t>(i));
    // Words present in every training image carry weight 0 and say nothing about the place.
    if (weights_[w] > 0.0) raw.push_back(BowEntry{w, weights_[w]});
  }
  std::sort(raw.begin(), raw.end(), [](const BowEntry& a, const BowEntry& b) { return a.word < b.word; });
  BowVector bow;
  double total = 0.0;
  for (const BowEntry& e : raw) {
    if (!bow.entries.empty() && bow.entries.back().word == e.word) {
      bow.entries.back().weight += e.weight;
    } else {
      bow.entries.push_back(e);
    }
    total += e.weight;
  }
  if (total > 0.0) {
    for (BowEntry& e : bow.entries) e.weight /= total;
  }
  return bow;
}

// ---------------------------------------------------------------------------------------------
// File format (docs/vocabulary.md): little-endian, FNV-1a 64 checksum trailer.
// ---------------------------------------------------------------------------------------------

namespace {

constexpr char kMagic[8] = {'V', 'I', 'M', 'S', 'V', 'O', 'C', '\0'};
constexpr size_t kNodeRecordBytes = 4 + kDescriptorBytes;  // parent, descriptor
constexpr size_t kWordRecordBytes = 4 + 8;                 // leaf node, weight
// A sanity bound far above any useful vocabulary, so a corrupt count cannot request huge memory.
constexpr uint32_t kMaxNodes = 50000000u;

class ByteWriter {
 public:
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  void f64(double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, sizeof(bits));
    u64(bits);
  }
  void raw(const void* data, size_t size) {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    bytes.insert(bytes.end(), p, p + size);
  }
  std::vector<uint8_t> bytes;
};

class ByteReader {
 public:
  ByteReader(const std::vector<uint8_t>& bytes, size_t limit, std::string source)
      : bytes_(bytes), limit_(limit), source_(std::move(source)) {}
  uint32_t u32(const char* what) {
    need(4, what);
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(bytes_[pos_ + static_cast<size_t>(i)]) << (8 * i);
    pos_ += 4;
    return v;
  }
  uint64_t u64(const char* what) {
    need(8, what);
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(bytes_[pos_ + static_cast<size_t>(i)]) << (8 * i);
    pos_ += 8;
    return v;
  }
  double f64(const char* what) {
    const uint64_t bits = u64(what);
    double v;
    std::memcpy(&v, &bits, sizeof(v));
    return v;
  }
  const uint8_t* raw(size_t size, const char* what) {
    need(size, what);
    const uint8_t* p = bytes_.data() + pos_;
    pos_ += size;
    return p;
  }
  size_t pos() const { return pos_; }

 private:
  void need(size_t n, const char* what) const {
    if (pos_ + n > limit_) {
      throw VocabularyFileError(source_ + ": truncated vocabulary file (" + std::to_string(bytes_.size()) +
                                " bytes) while reading " + what + " at byte " + std::to_string(pos_));
    }
  }
  const std::vector<uint8_t>& bytes_;
  size_t limit_;
  size_t pos_ = 0;
  std::string source_;
};

}  // namespace

std::vector<uint8_t> BinaryVocabulary::serialize() const {
  if (empty()) throw std::logic_error("BinaryVocabulary::serialize: the vocabulary is empty");
  ByteWriter w;
  w.raw(kMagic, sizeof(kMagic));
  w.u32(kFileVersion);
  w.u32(static_cast<uint32_t>(branching_));
  w.u32(static_cast<uint32_t>(levels_));
  w.u32(static_cast<uint32_t>(kDescriptorBytes));
  w.u32(static_cast<uint32_t>(descriptor_type_.size()));
  w.raw(descriptor_type_.data(), descriptor_type_.size());
  w.u64(num_training_images_);
  w.u32(static_cast<uint32_t>(nodes_.size()));
  w.u32(static_cast<uint32_t>(words_.size()));
  uint8_t desc[kDescriptorBytes];
  for (const Node& n : nodes_) {
    w.u32(n.parent);
    n.descriptor.toBytes(desc);
    w.raw(desc, kDescriptorBytes);
  }
  for (size_t i = 0; i < words_.size(); ++i) {
    w.u32(words_[i]);
    w.f64(weights_[i]);
  }
  w.u64(fnv1a64(w.bytes.data(), w.bytes.size()));
  return std::move(w.bytes);
}

BinaryVocabulary BinaryVocabulary::deserialize(const std::vector<uint8_t>& bytes, const std::string& source) {
  if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw VocabularyFileError(source + ": not a VIMS vocabulary file (bad magic)");
  ByteReader r(bytes, bytes.size(), source);
  r.raw(sizeof(kMagic), "magic");
  const uint32_t version = r.u32("version");
  if (version != kFileVersion)
    throw VocabularyFileError(source + ": unsupported vocabulary file version " + std::to_string(version) +
                              " (this build reads version " + std::to_string(kFileVersion) + ")");
  BinaryVocabulary voc;
  const uint32_t k = r.u32("branching");
  const uint32_t levels = r.u32("levels");
  const uint32_t desc_bytes = r.u32("descriptor size");
  if (k < 2 || k > 64 || levels < 1 || levels > 8)
    throw VocabularyFileError(source + ": corrupt header (branching " + std::to_string(k) + ", levels " +
                              std::to_string(levels) + ")");
  if (desc_bytes != static_cast<uint32_t>(kDescriptorBytes))
    throw VocabularyFileError(source + ": descriptors of " + std::to_string(desc_bytes) + " bytes, expected " +
                              std::to_string(kDescriptorBytes));
  const uint32_t type_len = r.u32("descriptor type length");
  if (type_len == 0 || type_len > 32)
    throw VocabularyFileError(source + ": corrupt header (descriptor type length " + std::to_string(type_len) + ")");
  const uint8_t* type_chars = r.raw(type_len, "descriptor type");
  voc.descriptor_type_.assign(reinterpret_cast<const char*>(type_chars), type_len);
  voc.num_training_images_ = r.u64("number of training images");
  const uint32_t num_nodes = r.u32("number of nodes");
  const uint32_t num_words = r.u32("number of words");
  if (num_nodes == 0 || num_nodes > kMaxNodes || num_words == 0 || num_words > num_nodes)
    throw VocabularyFileError(source + ": corrupt header (" + std::to_string(num_nodes) + " nodes, " +
                              std::to_string(num_words) + " words)");
  // The counts fix the file size exactly; checking it first turns a truncated or padded file
  // into one clear message instead of a checksum mismatch.
  const size_t expected = r.pos() + static_cast<size_t>(num_nodes) * kNodeRecordBytes +
                          static_cast<size_t>(num_words) * kWordRecordBytes + 8;
  if (bytes.size() != expected)
    throw VocabularyFileError(source + ": " + (bytes.size() < expected ? "truncated" : "oversized") +
                              " vocabulary file: header announces " + std::to_string(expected) + " bytes, file has " +
                              std::to_string(bytes.size()));
  uint64_t stored_checksum = 0;
  for (int i = 0; i < 8; ++i)
    stored_checksum |= static_cast<uint64_t>(bytes[expected - 8 + static_cast<size_t>(i)]) << (8 * i);
  if (fnv1a64(bytes.data(), expected - 8) != stored_checksum)
    throw VocabularyFileError(source + ": checksum mismatch, the vocabulary file is corrupt");

  voc.branching_ = static_cast<int>(k);
  voc.levels_ = static_cast<int>(levels);
  voc.nodes_.resize(num_nodes);
  for (uint32_t i = 0; i < num_nodes; ++i) {
    voc.nodes_[i].parent = r.u32("node parent");
    voc.nodes_[i].descriptor = BinaryDescriptor::fromBytes(r.raw(kDescriptorBytes, "node descriptor"));
  }
  voc.words_.resize(num_words);
  voc.weights_.resize(num_words);
  for (uint32_t i = 0; i < num_words; ++i) {
    voc.words_[i] = r.u32("word node");
    voc.weights_[i] = r.f64("word weight");
    if (!std::isfinite(voc.weights_[i]) || voc.weights_[i] < 0.0)
      throw VocabularyFileError(source + ": word " + std::to_string(i) + " has an invalid weight");
  }
  voc.linkTree(source);
  return voc;
}

void BinaryVocabulary::linkTree(const std::string& source) {
  auto fail = [&](const std::string& msg) { throw VocabularyFileError(source + ": inconsistent tree: " + msg); };
  if (nodes_[0].parent != kNoParent) fail("node 0 is not the root");
  for (uint32_t i = 1; i < nodes_.size(); ++i) {
    const uint32_t p = nodes_[i].parent;
    if (p >= i) fail("node " + std::to_string(i) + " has parent " + std::to_string(p) + " not before it");
    Node& parent = nodes_[p];
    if (parent.num_children == 0) {
      parent.first_child = i;
    } else if (parent.first_child + parent.num_children != i) {
      fail("children of node " + std::to_string(p) + " are not contiguous");
    }
    ++parent.num_children;
    if (parent.num_children > static_cast<uint32_t>(branching_))
      fail("node " + std::to_string(p) + " has too many children");
    nodes_[i].depth = parent.depth + 1;
    if (nodes_[i].depth > static_cast<uint32_t>(levels_)) fail("node " + std::to_string(i) + " is deeper than L");
  }
  for (uint32_t w = 0; w < words_.size(); ++w) {
    const uint32_t n = words_[w];
    if (n >= nodes_.size() || nodes_[n].num_children != 0 || nodes_[n].word != kNoWord)
      fail("word " + std::to_string(w) + " does not map to a distinct leaf");
    nodes_[n].word = w;
  }
  for (uint32_t i = 0; i < nodes_.size(); ++i) {
    if (nodes_[i].num_children == 0 && nodes_[i].word == kNoWord) fail("leaf " + std::to_string(i) + " has no word");
  }
}

void BinaryVocabulary::save(const std::string& path) const {
  const std::vector<uint8_t> bytes = serialize();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw std::runtime_error("failed to write vocabulary '" + path + "'");
}

BinaryVocabulary BinaryVocabulary::load(const std::string& path) {
  std::vector<uint8_t> bytes;
  try {
    bytes = readFileBytes(path);
  } catch (const std::runtime_error& e) {
    throw VocabularyFileError(std::string("vocabulary file ") + e.what());
  }
  return deserialize(bytes, path);
}

}  // namespace vims
