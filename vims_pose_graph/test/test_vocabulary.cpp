// Tests of the binary vocabulary tree, the BoW database and the ORB/BRIEF extraction.
// The place-recognition test uses procedural textures: a vocabulary is trained on one set of
// textures, a database is built from views of other textures, and the queries are rotated and
// shifted views of the database places (what a downward camera sees when it revisits a place
// with another heading).

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "vims_pose_graph/bow_database.h"
#include "vims_pose_graph/feature_extraction.h"
#include "vims_pose_graph/image_list.h"
#include "vims_pose_graph/vocabulary.h"

namespace vims {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Synthetic imagery
// ---------------------------------------------------------------------------------------------

/// A square procedural texture: a smooth background with random filled polygons, ellipses and
/// lines of random grey levels (plenty of corners at many scales), lightly blurred.
cv::Mat makeTexture(int size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(size, size, CV_8UC1, cv::Scalar(rng.uniform(70, 180)));
  for (int i = 0; i < 6; ++i) {  // large soft blobs: low-frequency shading
    cv::circle(img, cv::Point(rng.uniform(0, size), rng.uniform(0, size)), rng.uniform(size / 8, size / 3),
               cv::Scalar(rng.uniform(40, 220)), cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), size / 20.0);
  const int shapes = size * size / 1500;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point c(rng.uniform(0, size), rng.uniform(0, size));
    const cv::Scalar grey(rng.uniform(0, 256));
    switch (rng.uniform(0, 3)) {
      case 0: {
        const int n = rng.uniform(3, 6);
        const double r = rng.uniform(6.0, 30.0);
        const double a0 = rng.uniform(0.0, 2 * M_PI);
        std::vector<cv::Point> poly;
        for (int k = 0; k < n; ++k) {
          const double a = a0 + 2 * M_PI * k / n + rng.uniform(-0.4, 0.4);
          const double rr = r * rng.uniform(0.6, 1.2);
          poly.emplace_back(c.x + static_cast<int>(rr * std::cos(a)), c.y + static_cast<int>(rr * std::sin(a)));
        }
        cv::fillConvexPoly(img, poly, grey, cv::LINE_AA);
        break;
      }
      case 1:
        cv::ellipse(img, c, cv::Size(rng.uniform(4, 22), rng.uniform(4, 22)), rng.uniform(0.0, 180.0), 0, 360, grey,
                    cv::FILLED, cv::LINE_AA);
        break;
      default: {
        const double a = rng.uniform(0.0, 2 * M_PI);
        const double len = rng.uniform(15.0, 60.0);
        cv::line(img, c,
                 cv::Point(c.x + static_cast<int>(len * std::cos(a)), c.y + static_cast<int>(len * std::sin(a))), grey,
                 rng.uniform(1, 4), cv::LINE_AA);
      }
    }
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.8);
  return img;
}

/// The central out x out view of `texture` rotated by `angle_deg` about the point `shift` away
/// from the texture centre, with sensor noise. A crop of a larger texture avoids the artificial
/// borders a rotation would otherwise create.
cv::Mat viewOf(const cv::Mat& texture, double angle_deg, cv::Point2d shift, int out, uint64_t noise_seed) {
  const cv::Point2d center(texture.cols / 2.0 + shift.x, texture.rows / 2.0 + shift.y);
  cv::Mat M = cv::getRotationMatrix2D(center, angle_deg, 1.0);
  M.at<double>(0, 2) += out / 2.0 - center.x;
  M.at<double>(1, 2) += out / 2.0 - center.y;
  cv::Mat view;
  cv::warpAffine(texture, view, M, cv::Size(out, out), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat noise(view.size(), CV_16SC1);
  cv::RNG rng(noise_seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
  cv::Mat noisy;
  view.convertTo(noisy, CV_16SC1);
  noisy += noise;
  noisy.convertTo(view, CV_8UC1);
  return view;
}

constexpr int kTextureSize = 720;
constexpr int kViewSize = 400;

struct PlaceRecognitionData {
  std::vector<cv::Mat> training_views;
  std::vector<cv::Mat> place_views;
  std::vector<cv::Mat> query_views;
  std::vector<size_t> query_place;  ///< the place each query revisits
};

const PlaceRecognitionData& placeData() {
  // Built once (rendering is the slow part) and only read afterwards.
  static const PlaceRecognitionData data = [] {
    PlaceRecognitionData d;
    for (uint64_t s = 0; s < 30; ++s)
      d.training_views.push_back(viewOf(makeTexture(kTextureSize, 1000 + s), 0, {}, kViewSize, 1));
    // Revisits with another heading (right angles and arbitrary angles) and an offset of up to
    // ~20 px, plus one revisit with the same heading.
    const std::vector<double> angles = {90, 180, 270, 30, 135, 200, 315, 0};
    const std::vector<cv::Point2d> shifts = {{8, -5}, {-12, 6}, {4, 15},  {-6, -9},
                                             {15, 3}, {-3, 12}, {10, 10}, {-15, -4}};
    for (size_t place = 0; place < 20; ++place) {
      const cv::Mat texture = makeTexture(kTextureSize, 5000 + place);
      d.place_views.push_back(viewOf(texture, 0, {}, kViewSize, 2));
      for (size_t a = 0; a < angles.size(); ++a) {
        d.query_views.push_back(
            viewOf(texture, angles[a], shifts[(a + place) % shifts.size()], kViewSize, 100 + place * 10 + a));
        d.query_place.push_back(place);
      }
    }
    return d;
  }();
  return data;
}

std::vector<std::vector<BinaryDescriptor>> extractAll(const std::vector<cv::Mat>& images, FeatureExtractor& extractor) {
  std::vector<std::vector<BinaryDescriptor>> out;
  for (const cv::Mat& img : images) out.push_back(extractor.extract(img).descriptors);
  return out;
}

/// Random descriptors scattered around a few random prototypes (flip ~10 % of the bits), so
/// the tree has real clusters to find.
std::vector<std::vector<BinaryDescriptor>> clusteredDescriptors(int images, int per_image, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<BinaryDescriptor> prototypes(64);
  for (auto& p : prototypes)
    for (auto& w : p.words) w = rng();
  std::vector<std::vector<BinaryDescriptor>> out(static_cast<size_t>(images));
  for (auto& img : out) {
    for (int i = 0; i < per_image; ++i) {
      BinaryDescriptor d = prototypes[rng() % prototypes.size()];
      for (int b = 0; b < 26; ++b) {
        const int bit = static_cast<int>(rng() % 256);
        d.words[static_cast<size_t>(bit >> 6)] ^= uint64_t{1} << (bit & 63);
      }
      img.push_back(d);
    }
  }
  return out;
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("vims_vocab_test_" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

VocabularyTrainingOptions smallOptions() {
  VocabularyTrainingOptions o;
  o.branching = 8;
  o.levels = 3;
  o.seed = 7;
  return o;
}

// ---------------------------------------------------------------------------------------------
// Descriptors and scoring
// ---------------------------------------------------------------------------------------------

TEST(BinaryDescriptor, HammingAndMatRoundTrip) {
  cv::Mat m(2, 32, CV_8UC1, cv::Scalar(0));
  m.at<uint8_t>(1, 0) = 0xFF;
  m.at<uint8_t>(1, 31) = 0x01;
  const auto d = descriptorsFromMat(m);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(hammingDistance(d[0], d[1]), 9);
  EXPECT_EQ(hammingDistance(d[1], d[1]), 0);
  const cv::Mat back = descriptorsToMat(d);
  EXPECT_EQ(cv::norm(back, m, cv::NORM_L1), 0.0);
  EXPECT_THROW(descriptorsFromMat(cv::Mat(2, 16, CV_8UC1)), std::invalid_argument);
  EXPECT_THROW(descriptorsFromMat(cv::Mat(2, 32, CV_32FC1)), std::invalid_argument);
}

TEST(BinaryDescriptor, BitwiseMajority) {
  std::vector<BinaryDescriptor> d(3);
  d[0].setBit(0);
  d[1].setBit(0);
  d[2].setBit(5);
  d[0].setBit(255);
  const BinaryDescriptor m = bitwiseMajority(d, {0, 1, 2});
  EXPECT_TRUE(m.bit(0));
  EXPECT_FALSE(m.bit(5));
  EXPECT_FALSE(m.bit(255));
  // A tie (1 of 2) gives 0.
  EXPECT_FALSE(bitwiseMajority(d, {0, 2}).bit(0));
  EXPECT_TRUE(bitwiseMajority(d, {0, 1}).bit(0));
}

TEST(BowScore, L1ScoreProperties) {
  BowVector a, b, c;
  a.entries = {{1, 0.5}, {4, 0.5}};
  b.entries = {{1, 0.25}, {7, 0.75}};
  c.entries = {{2, 3.0}};
  EXPECT_DOUBLE_EQ(bowScoreL1(a, a), 1.0);
  EXPECT_DOUBLE_EQ(bowScoreL1(a, c), 0.0);
  // 1 - 0.5 (|0.5 - 0.25| + 0.5 + 0.75) = 0.25 = sum of minima.
  EXPECT_DOUBLE_EQ(bowScoreL1(a, b), 0.25);
  EXPECT_DOUBLE_EQ(bowScoreL1(b, a), 0.25);
  // Scale invariance: unnormalised input is normalised first.
  BowVector a2 = a;
  for (auto& e : a2.entries) e.weight *= 7.0;
  EXPECT_DOUBLE_EQ(bowScoreL1(a2, b), 0.25);
  EXPECT_DOUBLE_EQ(bowScoreL1(BowVector{}, a), 0.0);
  EXPECT_DOUBLE_EQ(a.weight(4), 0.5);
  EXPECT_DOUBLE_EQ(a.weight(5), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Training, transform, file format
// ---------------------------------------------------------------------------------------------

TEST(BinaryVocabulary, TrainsAWellFormedTree) {
  const auto images = clusteredDescriptors(20, 200, 3);
  const BinaryVocabulary voc = BinaryVocabulary::train(images, smallOptions());
  EXPECT_EQ(voc.branching(), 8);
  EXPECT_EQ(voc.levels(), 3);
  EXPECT_GT(voc.numWords(), 64u);
  EXPECT_LE(voc.numWords(), 512u);
  EXPECT_EQ(voc.numTrainingImages(), 20u);
  for (WordId w = 0; w < voc.numWords(); ++w) EXPECT_GE(voc.wordWeight(w), 0.0);
  // A BoW vector is sorted, unique, positive and L1-normalised.
  const BowVector v = voc.transform(images[0]);
  ASSERT_FALSE(v.empty());
  EXPECT_NEAR(v.l1Norm(), 1.0, 1e-12);
  for (size_t i = 1; i < v.entries.size(); ++i) EXPECT_LT(v.entries[i - 1].word, v.entries[i].word);
  for (const BowEntry& e : v.entries) EXPECT_GT(e.weight, 0.0);
}

TEST(BinaryVocabulary, DeterministicForASeed) {
  const auto images = clusteredDescriptors(10, 150, 4);
  VocabularyTrainingOptions o = smallOptions();
  const auto bytes1 = BinaryVocabulary::train(images, o).serialize();
  const auto bytes2 = BinaryVocabulary::train(images, o).serialize();
  EXPECT_EQ(bytes1, bytes2);
  o.seed = 8;
  EXPECT_NE(BinaryVocabulary::train(images, o).serialize(), bytes1);
}

TEST(BinaryVocabulary, RejectsUnusableInput) {
  EXPECT_THROW(BinaryVocabulary::train({}, smallOptions()), std::invalid_argument);
  EXPECT_THROW(BinaryVocabulary::train(clusteredDescriptors(1, 50, 1), smallOptions()), std::invalid_argument);
  VocabularyTrainingOptions bad = smallOptions();
  bad.branching = 1;
  EXPECT_THROW(BinaryVocabulary::train(clusteredDescriptors(3, 50, 1), bad), std::invalid_argument);
  EXPECT_THROW(BinaryVocabulary().transform({}), std::logic_error);
}

TEST(BinaryVocabulary, DirectIndexCoversEveryFeatureOnce) {
  const auto images = clusteredDescriptors(10, 200, 5);
  const BinaryVocabulary voc = BinaryVocabulary::train(images, smallOptions());
  FeatureVector direct;
  const BowVector with_direct = voc.transform(images[3], &direct, 2);
  const BowVector plain = voc.transform(images[3]);
  EXPECT_EQ(with_direct.entries.size(), plain.entries.size());
  std::vector<int> seen(images[3].size(), 0);
  for (const auto& [node, features] : direct) {
    (void)node;
    for (uint32_t f : features) seen.at(f)++;
  }
  for (int s : seen) EXPECT_EQ(s, 1);
  EXPECT_GT(direct.size(), 1u);
  EXPECT_LE(direct.size(), 64u);  // at most k^2 nodes at depth 2
  EXPECT_THROW(voc.transform(images[3], &direct, 0), std::invalid_argument);
  EXPECT_THROW(voc.transform(images[3], &direct, 4), std::invalid_argument);
}

TEST(BinaryVocabulary, SaveLoadRoundTripGivesIdenticalBowVectors) {
  TempDir dir;
  const auto images = clusteredDescriptors(12, 200, 6);
  const BinaryVocabulary voc = BinaryVocabulary::train(images, smallOptions());
  const std::string path = dir.file("voc.bin");
  voc.save(path);
  const BinaryVocabulary loaded = BinaryVocabulary::load(path);
  EXPECT_EQ(loaded.serialize(), voc.serialize());
  EXPECT_EQ(loaded.numWords(), voc.numWords());
  EXPECT_EQ(loaded.descriptorType(), "orb");
  for (const auto& img : images) {
    const BowVector a = voc.transform(img);
    const BowVector b = loaded.transform(img);
    ASSERT_EQ(a.entries.size(), b.entries.size());
    for (size_t i = 0; i < a.entries.size(); ++i) {
      EXPECT_EQ(a.entries[i].word, b.entries[i].word);
      EXPECT_EQ(a.entries[i].weight, b.entries[i].weight);  // bit-exact
    }
  }
}

TEST(BinaryVocabulary, CorruptOrTruncatedFilesGiveClearErrors) {
  TempDir dir;
  const BinaryVocabulary voc = BinaryVocabulary::train(clusteredDescriptors(8, 150, 7), smallOptions());
  const std::vector<uint8_t> good = voc.serialize();
  auto expectError = [&](const std::vector<uint8_t>& bytes, const std::string& needle) {
    const std::string path = dir.file("bad.voc");
    {
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
    try {
      BinaryVocabulary::load(path);
      ADD_FAILURE() << "no error for a file that should contain '" << needle << "'";
    } catch (const VocabularyFileError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
      EXPECT_NE(msg.find(path), std::string::npos) << msg;  // the message names the file
    }
  };
  expectError(std::vector<uint8_t>(good.begin(), good.end() - 100), "truncated");
  expectError(std::vector<uint8_t>(good.begin(), good.begin() + 30), "truncated");
  expectError(std::vector<uint8_t>(good.begin(), good.begin() + 5), "magic");
  expectError({}, "magic");
  std::vector<uint8_t> flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  expectError(flipped, "checksum");
  std::vector<uint8_t> version = good;
  version[8] = 99;
  expectError(version, "version");
  std::vector<uint8_t> padded = good;
  padded.push_back(0);
  expectError(padded, "oversized");
  EXPECT_THROW(BinaryVocabulary::load(dir.file("missing.voc")), VocabularyFileError);
}

TEST(VocabularyTrainingOptions, FromReader) {
  const auto o = VocabularyTrainingOptions::fromReader(
      ConfigReader::fromString("branching: 10\nlevels: 5\nseed: 3\ndescriptor_type: brief\n"));
  EXPECT_EQ(o.branching, 10);
  EXPECT_EQ(o.levels, 5);
  EXPECT_EQ(o.seed, 3u);
  EXPECT_EQ(o.descriptor_type, "brief");
  const auto round = VocabularyTrainingOptions::fromReader(ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(round.toYaml(), o.toYaml());
  try {
    VocabularyTrainingOptions::fromReader(ConfigReader::fromString("branchng: 8\n"));
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("branchng"), std::string::npos);
  }
  try {
    VocabularyTrainingOptions::fromReader(ConfigReader::fromString("levels: 0\n"));
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("levels"), std::string::npos);
  }
  EXPECT_THROW(VocabularyTrainingOptions::fromReader(ConfigReader::fromString("descriptor_type: sift\n")), ConfigError);
}

TEST(FeatureExtractionOptions, FromReader) {
  const auto o =
      FeatureExtractionOptions::fromReader(ConfigReader::fromString("descriptor: brief\nmax_features: 300\n"));
  EXPECT_EQ(o.descriptor, DescriptorType::kBrief);
  EXPECT_EQ(o.max_features, 300);
  EXPECT_EQ(FeatureExtractionOptions::fromReader(ConfigReader::fromString(o.toYaml())).toYaml(), o.toYaml());
  EXPECT_THROW(FeatureExtractionOptions::fromReader(ConfigReader::fromString("descriptor: surf\n")), ConfigError);
  EXPECT_THROW(FeatureExtractionOptions::fromReader(ConfigReader::fromString("max_feature: 3\n")), ConfigError);
}

TEST(ImageList, DirectoryAndListFile) {
  TempDir dir;
  const cv::Mat img(40, 40, CV_8UC1, cv::Scalar(100));
  cv::imwrite(dir.file("b.png"), img);
  cv::imwrite(dir.file("a.PNG"), img);
  { std::ofstream(dir.file("notes.txt")) << "not an image"; }
  const auto from_dir = listTrainingImages(dir.file(""));
  ASSERT_EQ(from_dir.size(), 2u);
  EXPECT_NE(from_dir[0].find("a.PNG"), std::string::npos);
  { std::ofstream(dir.file("list.txt")) << "# training images\nb.png\n\n  a.PNG  \n"; }
  const auto from_list = listTrainingImages(dir.file("list.txt"));
  ASSERT_EQ(from_list.size(), 2u);
  EXPECT_EQ(from_list[0], dir.file("b.png"));
  EXPECT_THROW(listTrainingImages(dir.file("nope")), std::runtime_error);
}

// ---------------------------------------------------------------------------------------------
// Database
// ---------------------------------------------------------------------------------------------

TEST(BowDatabase, QueryAndRestrictedQueryAgree) {
  const auto images = clusteredDescriptors(30, 150, 9);
  auto voc = std::make_shared<const BinaryVocabulary>(BinaryVocabulary::train(images, smallOptions()));
  BowDatabase db(voc, 2);
  for (const auto& img : images) db.add(img);
  EXPECT_EQ(db.size(), 30u);
  EXPECT_FALSE(db.featureVector(4).empty());
  const BowVector q = voc->transform(images[4]);
  const auto all = db.query(q, 30);
  ASSERT_FALSE(all.empty());
  EXPECT_EQ(all[0].image, 4u);
  EXPECT_NEAR(all[0].score, 1.0, 1e-12);
  for (size_t i = 1; i < all.size(); ++i) EXPECT_GE(all[i - 1].score, all[i].score);
  // Inverted-index scores equal the direct L1 score.
  for (const auto& r : all) EXPECT_NEAR(r.score, bowScoreL1(q, db.bowVector(r.image)), 1e-12);
  // Restricting to a subset that excludes the best image returns only subset members, with the
  // same scores, best first.
  const std::vector<ImageId> subset = {1, 7, 7, 12, 25, 999};
  const auto restricted = db.queryAmong(q, subset, 10);
  ASSERT_EQ(restricted.size(), 4u);
  for (const auto& r : restricted) {
    EXPECT_TRUE(r.image == 1 || r.image == 7 || r.image == 12 || r.image == 25);
    for (const auto& a : all) {
      if (a.image == r.image) {
        EXPECT_NEAR(a.score, r.score, 1e-12);
      }
    }
  }
  for (size_t i = 1; i < restricted.size(); ++i) EXPECT_GE(restricted[i - 1].score, restricted[i].score);
  EXPECT_EQ(db.queryAmong(q, {4, 1}, 1).at(0).image, 4u);
  EXPECT_EQ(db.query(q, 3).size(), 3u);
  EXPECT_TRUE(db.query(BowVector{}, 3).empty());
  EXPECT_THROW(db.bowVector(30), std::out_of_range);
}

// ---------------------------------------------------------------------------------------------
// Place recognition under rotation: ORB vs BRIEF
// ---------------------------------------------------------------------------------------------

struct RecognitionResult {
  int queries = 0;
  int top1 = 0;
  double rate() const { return static_cast<double>(top1) / queries; }
};

RecognitionResult recognitionRate(DescriptorType type) {
  const PlaceRecognitionData& data = placeData();
  FeatureExtractionOptions fo;
  fo.descriptor = type;
  fo.max_features = 500;
  FeatureExtractor extractor(fo);
  VocabularyTrainingOptions vo;
  vo.branching = 8;
  vo.levels = 4;
  vo.seed = 1;
  vo.descriptor_type = toString(type);
  auto voc =
      std::make_shared<const BinaryVocabulary>(BinaryVocabulary::train(extractAll(data.training_views, extractor), vo));
  BowDatabase db(voc, 2);
  for (const cv::Mat& view : data.place_views) db.add(extractor.extract(view).descriptors);

  RecognitionResult r;
  for (size_t i = 0; i < data.query_views.size(); ++i) {
    const auto best = db.query(voc->transform(extractor.extract(data.query_views[i]).descriptors), 1);
    ++r.queries;
    if (!best.empty() && best[0].image == data.query_place[i]) ++r.top1;
  }
  return r;
}

TEST(PlaceRecognition, OrbIsRotationInvariantBriefIsNot) {
  const RecognitionResult orb = recognitionRate(DescriptorType::kOrb);
  const RecognitionResult brief = recognitionRate(DescriptorType::kBrief);
  std::cout << "[ INFO     ] top-1 over " << orb.queries << " rotated/shifted queries: ORB " << orb.rate() << ", BRIEF "
            << brief.rate() << std::endl;
  EXPECT_GE(orb.rate(), 0.9);
  EXPECT_LT(brief.rate(), orb.rate() - 0.3);
}

TEST(BriefDescriptor, PatternIsDeterministicAndUnoriented) {
  const cv::Mat img = viewOf(makeTexture(kTextureSize, 77), 0, {}, kViewSize, 3);
  std::vector<cv::KeyPoint> kps = {cv::KeyPoint(200, 200, 7, 0), cv::KeyPoint(200, 200, 7, 90), cv::KeyPoint(3, 3, 7)};
  const auto d1 = BriefDescriptor().compute(img, &kps);
  ASSERT_EQ(kps.size(), 2u);  // the border keypoint is dropped
  EXPECT_EQ(d1[0], d1[1]);    // the angle is ignored
  auto kps2 = kps;
  EXPECT_EQ(BriefDescriptor().compute(img, &kps2)[0], d1[0]);
  auto kps3 = kps;
  EXPECT_NE(BriefDescriptor(12345).compute(img, &kps3)[0], d1[0]);
}

}  // namespace
}  // namespace vims
