/// @file multiscale_map_file_write.cpp
/// @brief MultiScaleMap's map file: writing it (docs/pose_graph.md, "Map file"); reading it is
/// in multiscale_map_file.cpp.
#include <algorithm>
#include <fstream>
#include <string>

#include "map_file_format.h"

namespace vims {

using namespace map_file;

size_t MultiScaleMap::numNodesToWrite(MapSaveScope scope, uint32_t* num_sessions) const {
  // The loaded sessions come first and their keyframes are the first nodes (a map is loaded
  // before the run's first keyframe): kLoadedSessions writes those prefixes.
  *num_sessions = static_cast<uint32_t>(sessions_.size());
  if (scope == MapSaveScope::kLoadedSessions) {
    *num_sessions = 0;
    while (*num_sessions < sessions_.size() && sessions_[*num_sessions].loaded) ++*num_sessions;
  }
  size_t num_nodes = 0;
  while (num_nodes < nodes_.size() && nodes_[num_nodes].session < *num_sessions) ++num_nodes;
  return num_nodes;
}

void MultiScaleMap::writeKeypointBlock(MapFileWriter& w, PoseGraphNodeId id) const {
  const MapNode& n = nodes_[id];
  if (!n.hasVisualSubmap()) return;
  if (!resident_submaps_[id]) {
    // Paged from the loaded file: its bytes are the records (checked when the file was loaded
    // for their size; a corrupt block is copied with its checksum and stays detectable).
    w.raw(paged_->file->data() + paged_->blocks_begin + paged_->offset[id], n.num_keypoints * kKeypointRecordBytes);
    return;
  }
  const VisualSubmap& v = *resident_submaps_[id];
  for (size_t i = 0; i < v.keypoints.size(); ++i) {
    const cv::KeyPoint& kp = v.keypoints[i];
    w.f32(kp.pt.x);
    w.f32(kp.pt.y);
    w.f32(kp.size);
    w.f32(kp.angle);
    w.f32(kp.response);
    w.i32(kp.octave);
    w.f64(v.normalized[i].x());
    w.f64(v.normalized[i].y());
    uint8_t d[kDescriptorBytes];
    v.descriptors[i].toBytes(d);
    w.raw(d, kDescriptorBytes);
  }
}

void MultiScaleMap::writePayload(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope,
                                 uint32_t version, const std::vector<uint64_t>& block_checksums) const {
  w.str(vocabulary_ ? vocabulary_->descriptorType() : std::string());
  w.str(vocabulary_path);
  w.u64(vocabulary_checksum_);
  w.u64(vocabulary_ ? vocabulary_->numWords() : 0);

  uint32_t num_sessions = 0;
  const size_t num_nodes = numNodesToWrite(scope, &num_sessions);
  const auto kept = [num_nodes](PoseGraphNodeId id) { return id < num_nodes; };
  const std::vector<uint32_t>& parents =
      scope == MapSaveScope::kLoadedSessions ? loaded_session_parent_ : session_parent_;

  w.u32(num_sessions);
  for (uint32_t s = 0; s < num_sessions; ++s) {
    w.u32(sessions_[s].vio_session);
    w.u32(parents[s]);
    w.pose(sessions_[s].T_b_c);
  }
  w.u32(static_cast<uint32_t>(num_nodes));
  for (size_t node = 0; node < num_nodes; ++node) {
    const MapNode& n = nodes_[node];
    w.f64(n.pose.t);
    w.u32(n.session);
    w.pose(n.pose.T_odom_b);
    w.vec(n.pose.p_w_b);
    w.f64(n.pose.yaw_w_b);
    w.u8(n.magnetic_coverage ? 1 : 0);
    w.u32(n.num_keypoints);
    if (version >= 4)
      w.u64(block_checksums[node]);
    else
      writeKeypointBlock(w, static_cast<PoseGraphNodeId>(node));
    w.u32(static_cast<uint32_t>(n.bow.entries.size()));
    for (const BowEntry& e : n.bow.entries) {
      w.u32(e.word);
      w.f64(e.weight);
    }
  }
  w.u32(static_cast<uint32_t>(std::count_if(sequential_edges_.begin(), sequential_edges_.end(),
                                            [&](const SequentialEdge& e) { return kept(e.from) && kept(e.to); })));
  for (const SequentialEdge& e : sequential_edges_) {
    if (!kept(e.from) || !kept(e.to)) continue;
    w.u32(e.from);
    w.u32(e.to);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
  }
  w.u32(static_cast<uint32_t>(std::count_if(loop_edges_.begin(), loop_edges_.end(),
                                            [&](const LoopEdge& e) { return kept(e.match) && kept(e.query); })));
  for (const LoopEdge& e : loop_edges_) {
    if (!kept(e.match) || !kept(e.query)) continue;
    w.u32(e.id);
    w.u32(e.match);
    w.u32(e.query);
    w.pose(e.T_match_query);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
    w.u8(e.enabled ? 1 : 0);
  }
  w.u32(static_cast<uint32_t>(std::count_if(yaw_measurements_.begin(), yaw_measurements_.end(),
                                            [&](const YawMeasurement& m) { return kept(m.node); })));
  for (const YawMeasurement& m : yaw_measurements_) {
    if (!kept(m.node)) continue;
    w.u32(m.node);
    w.f64(m.u_l.x());
    w.f64(m.u_l.y());
    w.f64(m.heading_rad);
  }
  w.u32(static_cast<uint32_t>(std::count_if(magnetic_submaps_.begin(), magnetic_submaps_.end(),
                                            [&](const MagneticSubmap& m) { return kept(m.tied_node); })));
  for (const MagneticSubmap& m : magnetic_submaps_) {
    if (!kept(m.tied_node)) continue;
    w.u32(m.tied_node);
    w.f64(m.t);
    w.u32(static_cast<uint32_t>(m.coil));
    w.vec(m.signature_enu);
    w.f64(m.radius_m);
    w.u32(m.num_members);
  }
}

void MultiScaleMap::writeFile(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope,
                              uint32_t version) const {
  if (version != 3 && version != kFileVersion)
    throw std::invalid_argument("MultiScaleMap: cannot write map file version " + std::to_string(version) +
                                " (writes 3 and " + std::to_string(kFileVersion) + ")");
  // Version 4: the index (poses, BoW vectors, edges, magnetic submaps) with its checksum, then
  // each keyframe's keypoint records as one block with its own checksum in the index, so a
  // loader reads the index and leaves the blocks in the file until a loop needs one.
  std::vector<uint64_t> block_checksums;
  uint64_t blocks_size = 0;
  uint32_t num_sessions = 0;
  const size_t num_nodes = numNodesToWrite(scope, &num_sessions);
  if (version >= 4) {
    block_checksums.resize(num_nodes, 0);
    for (PoseGraphNodeId id = 0; id < num_nodes; ++id) {
      const MapNode& n = nodes_[id];
      if (!n.hasVisualSubmap()) continue;
      blocks_size += uint64_t{n.num_keypoints} * kKeypointRecordBytes;
      if (!resident_submaps_[id]) {
        block_checksums[id] = paged_->checksum[id];
        continue;
      }
      std::vector<uint8_t> block;
      MapFileWriter bw(&block);
      writeKeypointBlock(bw, id);
      block_checksums[id] = bw.flushedChecksum();
    }
  }
  MapFileWriter counter;
  writePayload(counter, vocabulary_path, scope, version, block_checksums);
  w.raw(reinterpret_cast<const uint8_t*>(kMagic), 8);
  w.u32(version);
  w.u64(counter.size());
  if (version >= 4) w.u64(blocks_size);
  writePayload(w, vocabulary_path, scope, version, block_checksums);
  w.finishWithChecksum();
  if (version < 4) return;
  for (PoseGraphNodeId id = 0; id < num_nodes; ++id) writeKeypointBlock(w, id);
  w.flushedChecksum();
}

std::vector<uint8_t> MultiScaleMap::serialize(const std::string& vocabulary_path, MapSaveScope scope,
                                              uint32_t version) const {
  std::vector<uint8_t> bytes;
  MapFileWriter w(&bytes);
  writeFile(w, vocabulary_path, scope, version);
  return bytes;
}

void MultiScaleMap::save(const std::string& path, const std::string& vocabulary_path, MapSaveScope scope,
                         uint32_t version) const {
  // Write to a temporary file and rename, so a crash mid-write never leaves a half map under
  // the real name (and a map loaded from `path`, which stays mapped, keeps its bytes).
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write map file '" + tmp + "'");
    MapFileWriter w(&out);
    writeFile(w, vocabulary_path, scope, version);
    out.flush();
    if (!out) throw std::runtime_error("I/O error writing map file '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error("cannot rename '" + tmp + "' to map file '" + path + "'");
}

}  // namespace vims
