// The wearer's segments from de Leva (1996) Table 4, scaled to the height, with seeded per-parameter variation.
// Sources of every number: docs/wearer.md.
#include "exoid/model/anthropometry.hpp"
#include "exoid/common/fail.hpp"

#include <cmath>
#include <random>
#include <utility>

namespace exoid {
namespace {

// de Leva 1996, Table 4: mass fraction, CoM fraction from the proximal/cranial endpoint, radii of gyration
// (sagittal, transverse, longitudinal; fractions of the length), length (m) of the reference subject. Rows in
// SegmentKind order. Head VERT-CERV and trunk CERV-XYPH / XYPH-OMPH / OMPH-MIDH are the table's C7-based rows,
// whose lengths chain (242.1 + 215.5 + 145.7 = 603.3 mm = CERV-MIDH, male).
constexpr SegmentRow kMale[kNumSegmentKinds] = {
    {0.0694, 0.5002, 0.303, 0.315, 0.261, 0.2429},  // head, VERT-CERV
    {0.1596, 0.5066, 0.505, 0.320, 0.465, 0.2421},  // upper trunk, CERV-XYPH
    {0.1633, 0.4502, 0.482, 0.383, 0.468, 0.2155},  // middle trunk, XYPH-OMPH
    {0.1117, 0.6115, 0.615, 0.551, 0.587, 0.1457},  // lower trunk, OMPH-MIDH
    {0.0271, 0.5772, 0.285, 0.269, 0.158, 0.2817},  // upper arm, SJC-EJC
    {0.0162, 0.4574, 0.276, 0.265, 0.121, 0.2689},  // forearm, EJC-WJC
    {0.0061, 0.7900, 0.628, 0.513, 0.401, 0.0862},  // hand, WJC-MET3
    {0.1416, 0.4095, 0.329, 0.329, 0.149, 0.4222},  // thigh, HJC-KJC
    {0.0433, 0.4459, 0.255, 0.249, 0.103, 0.4340},  // shank, KJC-LMAL
    {0.0137, 0.4415, 0.257, 0.245, 0.124, 0.2581},  // foot, HEEL-TTIP
};
constexpr SegmentRow kFemale[kNumSegmentKinds] = {
    {0.0668, 0.4841, 0.271, 0.295, 0.261, 0.2437},
    {0.1545, 0.5050, 0.466, 0.314, 0.449, 0.2280},
    {0.1465, 0.4512, 0.433, 0.354, 0.415, 0.2053},
    {0.1247, 0.4920, 0.433, 0.402, 0.444, 0.1815},
    {0.0255, 0.5754, 0.278, 0.260, 0.148, 0.2751},
    {0.0138, 0.4559, 0.261, 0.257, 0.094, 0.2643},
    {0.0056, 0.7474, 0.531, 0.454, 0.335, 0.0780},
    {0.1478, 0.3612, 0.369, 0.364, 0.162, 0.3685},
    {0.0481, 0.4416, 0.271, 0.267, 0.093, 0.4323},
    {0.0129, 0.4014, 0.299, 0.279, 0.139, 0.2283},
};

constexpr const char* kNames[kNumSegmentKinds] = {"head",     "upper_trunk", "middle_trunk", "lower_trunk", "upper_arm",
                                                  "forearm",  "hand",        "thigh",        "shank",       "foot"};

// Uniform in [-1, 1) from 53 bits of mt19937_64 (identical on every platform, unlike std::uniform_real_distribution).
double symmetricUniform(std::mt19937_64& rng) {
  constexpr double k = 1.0 / 9007199254740992.0;  // 2^-53
  return 2.0 * static_cast<double>(rng() >> 11) * k - 1.0;
}

using common::fail;

// Principal moments of a physical body satisfy the triangle inequality: each is at most the sum of the others.
bool triangle(const Eigen::Vector3d& I) { return I[0] <= I[1] + I[2] && I[1] <= I[0] + I[2] && I[2] <= I[0] + I[1]; }

// The table's radii on the segment's principal axes (x forward, y left, z up; the foot's long axis is x).
Eigen::Vector3d radiiOnAxes(const SegmentRow& r, SegmentKind kind) {
  if (kind == SegmentKind::Foot) return {r.r_longitudinal, r.r_sagittal, r.r_transverse};
  return {r.r_sagittal, r.r_transverse, r.r_longitudinal};
}

// One segment drawn from the table: mass (not yet renormalised), CoM fraction and radii varied; the radii
// redrawn until the principal moments are physical (at most 1000 draws; the table's own radii always are).
BodySegment drawSegment(const WearerSpec& s, SegmentKind kind, int side, std::mt19937_64& rng) {
  const SegmentRow& row = deLevaRow(s.sex, kind);
  BodySegment seg;
  seg.kind = kind;
  seg.side = side;
  seg.name = segmentName(kind, side);
  seg.length = row.length_m * s.height_m / deLevaStature(s.sex);
  const double v = s.variation;
  seg.mass = row.mass_fraction * s.mass_kg * (1.0 + v * symmetricUniform(rng));
  seg.com_fraction = row.com_fraction * (1.0 + v * symmetricUniform(rng));
  const Eigen::Vector3d r0 = radiiOnAxes(row, kind);
  for (int attempt = 0; attempt < 1000; ++attempt) {
    for (int i = 0; i < 3; ++i) seg.radius[i] = r0[i] * (1.0 + v * symmetricUniform(rng));
    if (triangle(seg.radius.cwiseAbs2())) break;
    seg.radius = r0;
  }
  return seg;
}

}  // namespace

const SegmentRow& deLevaRow(Sex sex, SegmentKind kind) {
  return (sex == Sex::Male ? kMale : kFemale)[static_cast<int>(kind)];
}

double deLevaStature(Sex sex) { return sex == Sex::Male ? 1.741 : 1.735; }

const char* segmentKindName(SegmentKind kind) { return kNames[static_cast<int>(kind)]; }

std::string segmentName(SegmentKind kind, int side) {
  return std::string(side < 0 ? "right_" : side > 0 ? "left_" : "") + segmentKindName(kind);
}

bool isBilateral(SegmentKind kind) { return static_cast<int>(kind) >= static_cast<int>(SegmentKind::UpperArm); }

int Wearer::index(const std::string& name) const {
  for (size_t i = 0; i < segments.size(); ++i)
    if (segments[i].name == name) return static_cast<int>(i);
  return -1;
}

double Wearer::totalMass() const {
  double m = 0.0;
  for (const BodySegment& s : segments) m += s.mass;
  return m;
}

bool buildWearer(const WearerSpec& spec, Wearer& out, std::string* err) {
  if (!(spec.mass_kg > 0.0 && spec.mass_kg <= 300.0)) return fail(err, "wearer mass must be in (0, 300] kg");
  if (!(spec.height_m >= 1.0 && spec.height_m <= 2.5)) return fail(err, "wearer height must be in [1.0, 2.5] m");
  if (!(spec.variation >= 0.0 && spec.variation <= 0.5)) return fail(err, "wearer variation must be in [0, 0.5]");
  Wearer w;
  w.spec = spec;
  std::mt19937_64 rng(spec.seed);
  for (int k = 0; k < kNumSegmentKinds; ++k) {
    const SegmentKind kind = static_cast<SegmentKind>(k);
    if (isBilateral(kind)) {
      w.segments.push_back(drawSegment(spec, kind, -1, rng));
      w.segments.push_back(drawSegment(spec, kind, +1, rng));
    } else {
      w.segments.push_back(drawSegment(spec, kind, 0, rng));
    }
  }
  // A scale measures the body mass: the varied segment masses share it (the table's own fractions sum to
  // 1.0000 male, 0.9999 female, by rounding).
  const double scale = spec.mass_kg / w.totalMass();
  for (BodySegment& s : w.segments) {
    s.mass *= scale;
    s.inertia = s.mass * (s.radius * s.length).cwiseAbs2();
  }
  out = std::move(w);
  return true;
}

Eigen::Vector3d standingSegmentCom(const Wearer& w, const BodySegment& s) {
  const double H = w.spec.height_m;
  auto len = [&](SegmentKind k) { return deLevaRow(w.spec.sex, k).length_m * H / deLevaStature(w.spec.sex); };
  const double shank = len(SegmentKind::Shank), thigh = len(SegmentKind::Thigh);
  const double lower = len(SegmentKind::LowerTrunk), middle = len(SegmentKind::MiddleTrunk);
  const double upper = len(SegmentKind::UpperTrunk);
  const double ankle = standingAnkleHeight(w);
  const double shoulder = 0.818 * H - (ankle + shank + thigh);  // SJC above MIDH (Winter 2009 Fig. 4.1: 0.818 H)
  const double f = s.com_fraction, L = s.length;
  double x = 0.0, y = 0.0, z = 0.0;
  switch (s.kind) {
    case SegmentKind::Foot:
      x = (f - kHeelToAnkleFraction) * L;
      z = -(thigh + shank + 0.5 * ankle);
      break;
    case SegmentKind::Shank: z = -(thigh + f * L); break;
    case SegmentKind::Thigh: z = -f * L; break;
    case SegmentKind::LowerTrunk: z = (1.0 - f) * L; break;
    case SegmentKind::MiddleTrunk: z = lower + (1.0 - f) * L; break;
    case SegmentKind::UpperTrunk: z = lower + middle + (1.0 - f) * L; break;
    case SegmentKind::Head: z = lower + middle + upper + (1.0 - f) * L; break;
    case SegmentKind::UpperArm: z = shoulder - f * L; break;
    case SegmentKind::Forearm: z = shoulder - len(SegmentKind::UpperArm) - f * L; break;
    case SegmentKind::Hand: z = shoulder - len(SegmentKind::UpperArm) - len(SegmentKind::Forearm) - f * L; break;
  }
  const bool arm = s.kind == SegmentKind::UpperArm || s.kind == SegmentKind::Forearm || s.kind == SegmentKind::Hand;
  if (s.side != 0) y = s.side * 0.5 * (arm ? 0.259 : 0.191) * H;  // right (-1) at -y; Winter 2009 Fig. 4.1 widths
  return {x, y, z};
}

double standingAnkleHeight(const Wearer& w) {
  double chain = 0.0;
  for (SegmentKind k : {SegmentKind::Head, SegmentKind::UpperTrunk, SegmentKind::MiddleTrunk, SegmentKind::LowerTrunk,
                        SegmentKind::Thigh, SegmentKind::Shank})
    chain += deLevaRow(w.spec.sex, k).length_m;
  return w.spec.height_m * (1.0 - chain / deLevaStature(w.spec.sex));
}

double standingComHeight(const Wearer& w) {
  const double scale = w.spec.height_m / deLevaStature(w.spec.sex);
  const Sex sex = w.spec.sex;
  const double legs = deLevaRow(sex, SegmentKind::Shank).length_m + deLevaRow(sex, SegmentKind::Thigh).length_m;
  const double hip = standingAnkleHeight(w) + scale * legs;  // MIDH above the floor
  double mz = 0.0;
  for (const BodySegment& s : w.segments) mz += s.mass * (hip + standingSegmentCom(w, s).z());
  return mz / w.totalMass();
}

}  // namespace exoid
