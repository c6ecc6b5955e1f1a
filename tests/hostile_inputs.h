// Hostile inputs shared by the core and service tests: Draco bytes that Draco's
// decoder accepts but meshsmooth must refuse (a point cloud among them), and a fan whose centre
// has a huge valence.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>

#include "core/mesh.h"
#include "core/shapes/parametric.h"
#include "draco/compression/encode.h"
#include "draco/mesh/mesh.h"
#include "draco/point_cloud/point_cloud.h"
#include "gtest/gtest.h"

namespace meshsmooth::testing {

// Draco bytes of `m` written by Draco itself (sequential, raw indices), so that what
// meshsmooth's own encoder refuses to write can be uploaded: `positions` POSITION attributes
// (the second one shifted by 1 in z) and faces exactly as given, in range or not.
inline std::string RawDraco(const Mesh& m, int positions = 1) {
  draco::Mesh dm;
  const int32_t n = m.num_vertices();
  dm.set_num_points(n);
  for (int k = 0; k < positions; ++k) {
    draco::GeometryAttribute ga;
    ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
    const int id = dm.AddAttribute(ga, /*identity_mapping=*/true, n);
    for (int32_t i = 0; i < n; ++i) {
      const Vec3& p = m.positions[i];
      const float v[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z + k)};
      dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(i), v);
    }
  }
  for (const Triangle& t : m.triangles) {
    dm.AddFace({draco::PointIndex(static_cast<uint32_t>(t[0])), draco::PointIndex(static_cast<uint32_t>(t[1])),
                draco::PointIndex(static_cast<uint32_t>(t[2]))});
  }
  draco::Encoder encoder;
  encoder.SetSpeedOptions(10, 10);  // speed 10: indices stored as they are
  encoder.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
  draco::EncoderBuffer buf;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(dm, &buf).ok());
  return std::string(buf.data(), buf.size());
}

// Draco bytes of `m` with a texture coordinate per vertex (from its direction), written by
// Draco's Edgebreaker encoder at speed 0 (draco_encoder -cl 10), which predicts texture
// coordinates with its portable texture-coordinate scheme (orientation bits after the
// positions' data).
inline std::string TexturedEdgebreakerDraco(const Mesh& m) {
  draco::Mesh dm;
  const int32_t n = m.num_vertices();
  dm.set_num_points(n);
  draco::GeometryAttribute pos, uv;
  pos.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 3 * sizeof(float), 0);
  uv.Init(draco::GeometryAttribute::TEX_COORD, nullptr, 2, draco::DT_FLOAT32, false, 2 * sizeof(float), 0);
  const int pos_id = dm.AddAttribute(pos, /*identity_mapping=*/true, n);
  const int uv_id = dm.AddAttribute(uv, /*identity_mapping=*/true, n);
  for (int32_t i = 0; i < n; ++i) {
    const Vec3& p = m.positions[i];
    const float xyz[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
    const float st[2] = {static_cast<float>(0.5 + std::atan2(p.y, p.x) / (2 * std::numbers::pi)),
                         static_cast<float>(0.5 + 0.5 * p.z)};
    dm.attribute(pos_id)->SetAttributeValue(draco::AttributeValueIndex(i), xyz);
    dm.attribute(uv_id)->SetAttributeValue(draco::AttributeValueIndex(i), st);
  }
  for (const Triangle& t : m.triangles) {
    dm.AddFace({draco::PointIndex(static_cast<uint32_t>(t[0])), draco::PointIndex(static_cast<uint32_t>(t[1])),
                draco::PointIndex(static_cast<uint32_t>(t[2]))});
  }
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
  encoder.SetSpeedOptions(0, 0);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 11);
  encoder.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, 10);
  draco::EncoderBuffer buf;
  EXPECT_TRUE(encoder.EncodeMeshToBuffer(dm, &buf).ok());
  return std::string(buf.data(), buf.size());
}

// Three points (i, y, z), i = 0..2, as the only POSITION attribute of `pc`, a point cloud or a
// draco::Mesh (which then has no faces).
inline void PutThreePoints(draco::PointCloud& pc, float y, float z) {
  pc.set_num_points(3);
  draco::GeometryAttribute ga;
  ga.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false, 12, 0);
  const int att = pc.AddAttribute(ga, true, 3);
  for (int i = 0; i < 3; ++i) {
    const float v[3] = {static_cast<float>(i), y, z};
    pc.attribute(att)->SetAttributeValue(draco::AttributeValueIndex(i), v);
  }
}

// Draco bytes of a point cloud of three points: Draco decodes it, but it has no faces.
inline std::string DracoPointCloud() {
  draco::PointCloud pc;
  PutThreePoints(pc, 1.0f, 2.0f);
  draco::Encoder enc;
  draco::EncoderBuffer buf;
  EXPECT_TRUE(enc.EncodePointCloudToBuffer(pc, &buf).ok());
  return std::string(buf.data(), buf.size());
}

// The head of an Edgebreaker bitstream declaring `faces` faces and `vertices` vertices, as
// bitstream 1.2 writes it (raw uint32 counts, a count of new vertices first) or 2.2 (varints),
// followed by bytes no decoder gets far into. Draco's own checks on the counts hold.
inline std::string EdgebreakerHead(bool v22, uint32_t vertices, uint32_t faces) {
  std::string out = "DRACO";
  out += v22 ? std::string{'\x02', '\x02'} : std::string{'\x01', '\x02'};
  out += std::string{'\x01', '\x01', '\x00', '\x00', '\x00'};  // mesh, Edgebreaker, no flags, standard
  auto put = [&](uint32_t v) {
    if (!v22) {
      out.append(reinterpret_cast<const char*>(&v), 4);
      return;
    }
    for (; v >= 0x80; v >>= 7) out += static_cast<char>(0x80 | (v & 0x7f));
    out += static_cast<char>(v);
  };
  if (!v22) put(2);  // new vertices
  put(vertices);
  put(faces);
  out += '\x01';  // attribute data
  put(faces);     // symbols
  put(0);         // split symbols
  return out + std::string(1300, '\x0b');
}

// A 20 x 15 torus (1160 vertices here) with one face index set to 65535, which Draco's decoder
// accepts.
inline Mesh TorusWithIndexPastThePoints() {
  Mesh m = TwoRateTorus(20);
  m.triangles[5][1] = 65535;
  return m;
}

// A closed fan: a centre slightly above the unit circle's plane and `valence` vertices around
// it, one face per pair of neighbours. The centre is interior with that valence, every other
// vertex a boundary vertex of valence 3.
inline Mesh Fan(int32_t valence) {
  Mesh m;
  m.positions.push_back({0.0, 0.0, 0.1});
  for (int32_t i = 0; i < valence; ++i) {
    const double a = 2.0 * std::numbers::pi * i / valence;
    m.positions.push_back({std::cos(a), std::sin(a), 0.0});
  }
  for (int32_t i = 0; i < valence; ++i) m.triangles.push_back({0, 1 + i, 1 + (i + 1) % valence});
  return m;
}

// A closed bipyramid: `valence` vertices on the unit circle and two apexes at z = +-0.5, each
// apex of valence `valence`; the rim vertices have valence 4, and every face is a needle once
// the valence is large.
inline Mesh ClosedFan(int32_t valence) {
  Mesh m;
  for (int32_t i = 0; i < valence; ++i) {
    const double a = 2.0 * std::numbers::pi * i / valence;
    m.positions.push_back({std::cos(a), std::sin(a), 0.0});
  }
  const int32_t top = valence, bottom = valence + 1;
  m.positions.push_back({0.0, 0.0, 0.5});
  m.positions.push_back({0.0, 0.0, -0.5});
  for (int32_t i = 0; i < valence; ++i) {
    const int32_t j = (i + 1) % valence;
    m.triangles.push_back({i, j, top});
    m.triangles.push_back({j, i, bottom});
  }
  return m;
}

}  // namespace meshsmooth::testing
