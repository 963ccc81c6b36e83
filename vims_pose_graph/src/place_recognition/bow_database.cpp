#include "vims_pose_graph/bow_database.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace vims {

BowDatabase::BowDatabase(std::shared_ptr<const BinaryVocabulary> vocabulary, int direct_index_depth)
    : vocabulary_(std::move(vocabulary)), direct_index_depth_(direct_index_depth) {
  if (!vocabulary_ || vocabulary_->empty()) throw std::invalid_argument("BowDatabase: the vocabulary is empty");
  if (direct_index_depth_ < 1)
    throw std::invalid_argument("BowDatabase: direct_index_depth must be >= 1, got " +
                                std::to_string(direct_index_depth));
  direct_index_depth_ = std::min(direct_index_depth_, vocabulary_->levels());
  inverted_.resize(vocabulary_->numWords());
}

ImageId BowDatabase::add(const std::vector<BinaryDescriptor>& descriptors) {
  FeatureVector direct;
  BowVector bow = vocabulary_->transform(descriptors, &direct, direct_index_depth_);
  return add(bow, std::move(direct));
}

ImageId BowDatabase::add(const BowVector& bow, FeatureVector direct_index) {
  const ImageId id = static_cast<ImageId>(images_.size());
  // Store the normalised vector: the inverted-index score below assumes unit L1 norm.
  // Re-establish the BowVector invariant (sorted, unique, positive) for hand-made input: the
  // merge-walk scoring of queryAmong() relies on it.
  Image img;
  for (const BowEntry& e : bow.entries) {
    if (e.word >= inverted_.size())
      throw std::invalid_argument("BowDatabase::add: word " + std::to_string(e.word) + " is not in the vocabulary");
    if (e.weight > 0.0) img.bow.entries.push_back(e);
  }
  std::sort(img.bow.entries.begin(), img.bow.entries.end(),
            [](const BowEntry& a, const BowEntry& b) { return a.word < b.word; });
  std::vector<BowEntry> merged;
  for (const BowEntry& e : img.bow.entries) {
    if (!merged.empty() && merged.back().word == e.word) {
      merged.back().weight += e.weight;
    } else {
      merged.push_back(e);
    }
  }
  img.bow.entries.swap(merged);
  const double norm = img.bow.l1Norm();
  for (BowEntry& e : img.bow.entries) e.weight /= norm;
  for (const BowEntry& e : img.bow.entries) inverted_[e.word].push_back(Posting{id, e.weight});
  img.direct = std::move(direct_index);
  images_.push_back(std::move(img));
  return id;
}

const BowVector& BowDatabase::bowVector(ImageId id) const { return images_.at(id).bow; }

const FeatureVector& BowDatabase::featureVector(ImageId id) const { return images_.at(id).direct; }

std::vector<BowQueryResult> BowDatabase::selectBest(std::vector<BowQueryResult> results, size_t max_results) {
  auto better = [](const BowQueryResult& a, const BowQueryResult& b) {
    return a.score > b.score || (a.score == b.score && a.image < b.image);
  };
  if (results.size() > max_results) {
    std::partial_sort(results.begin(), results.begin() + static_cast<std::ptrdiff_t>(max_results), results.end(),
                      better);
    results.resize(max_results);
  } else {
    std::sort(results.begin(), results.end(), better);
  }
  return results;
}

std::vector<BowQueryResult> BowDatabase::query(const BowVector& query, size_t max_results) const {
  if (max_results == 0 || images_.empty()) return {};
  const double qnorm = query.l1Norm();
  if (qnorm <= 0.0) return {};
  // For non-negative unit-L1 vectors a and b,
  //   1 - 0.5 |a - b|_1 = 1 - 0.5 (sum_i a_i + sum_i b_i - 2 sum_i min(a_i, b_i)) = sum_i min(a_i, b_i),
  // so the score accumulates over the words the query shares with each image: exactly the
  // postings of the inverted index, and the same value as bowScoreL1.
  std::vector<double> score(images_.size(), 0.0);
  std::vector<char> touched(images_.size(), 0);
  std::vector<ImageId> hits;
  for (const BowEntry& q : query.entries) {
    if (q.word >= inverted_.size() || q.weight <= 0.0) continue;
    const double qw = q.weight / qnorm;
    for (const Posting& p : inverted_[q.word]) {
      score[p.image] += std::min(qw, p.weight);
      if (!touched[p.image]) {
        touched[p.image] = 1;
        hits.push_back(p.image);
      }
    }
  }
  std::vector<BowQueryResult> results;
  results.reserve(hits.size());
  for (ImageId id : hits) results.push_back(BowQueryResult{id, std::min(1.0, score[id])});
  return selectBest(std::move(results), max_results);
}

std::vector<BowQueryResult> BowDatabase::queryAmong(const BowVector& query, const std::vector<ImageId>& candidates,
                                                    size_t max_results) const {
  if (max_results == 0) return {};
  std::vector<ImageId> ids = candidates;
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::vector<BowQueryResult> results;
  for (ImageId id : ids) {
    if (id >= images_.size()) continue;
    const double s = bowScoreL1(query, images_[id].bow);
    if (s > 0.0) results.push_back(BowQueryResult{id, s});
  }
  return selectBest(std::move(results), max_results);
}

}  // namespace vims
