#pragma once
// The wearer's body from anthropometric tables (docs/wearer.md): de Leva (1996), "Adjustments to
// Zatsiorsky-Seluyanov's segment inertia parameters", J. Biomech. 29(9):1223-1230, Table 4 — per sex and
// segment: mass fraction of the body mass, longitudinal CoM position (fraction of the segment length from its
// proximal / cranial endpoint), radii of gyration about the sagittal, transverse and longitudinal axes
// (fractions of the segment length), and the segment length of the table's reference subject (stature
// 1.741 m male, 1.735 m female), scaled here in proportion to the wearer's height.
//
// buildWearer turns {mass, height, sex, seed, variation} into the per-segment mass, length, CoM fraction and
// principal moments m (r L)^2 about the CoM; `variation` multiplies each of mass, CoM fraction and radii by an
// independent seeded factor 1 + u, u ~ U[-variation, variation] (masses then renormalised to the body mass,
// which a scale measures), so that a simulated person is not the table. Startup code (allocates).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace exoid {

enum class Sex { Male, Female };

/// The segments of de Leva's Table 4 that exoid uses. The trunk is the three sub-segments of the
/// C7 (CERV) - mid-hip (MIDH) chain: upper (CERV-XYPH), middle (XYPH-OMPH), lower (OMPH-MIDH); the head is
/// VERT-CERV. Arms: shoulder (SJC) - elbow (EJC) - wrist (WJC) - 3rd metacarpal (MET3). Legs: hip (HJC) - knee
/// (KJC) - lateral malleolus (LMAL); foot heel (HEEL) - toe tip (TTIP).
enum class SegmentKind { Head, UpperTrunk, MiddleTrunk, LowerTrunk, UpperArm, Forearm, Hand, Thigh, Shank, Foot };
inline constexpr int kNumSegmentKinds = 10;

/// One row of de Leva's Table 4 (one sex).
struct SegmentRow {
  double mass_fraction;  ///< of the body mass
  double com_fraction;   ///< CoM from the proximal (cranial) endpoint, fraction of the length
  double r_sagittal;     ///< radius of gyration about the sagittal (antero-posterior) axis, fraction of the length
  double r_transverse;   ///< about the transverse (medio-lateral) axis
  double r_longitudinal; ///< about the segment's long axis
  double length_m;       ///< segment length of the table's reference subject, m
};

/// de Leva 1996 Table 4, the row of `kind` for `sex`.
const SegmentRow& deLevaRow(Sex sex, SegmentKind kind);
/// The table's reference stature (1.741 m male, 1.735 m female), to which its lengths belong.
double deLevaStature(Sex sex);
/// Segment name in snake case ("upper_trunk", "thigh", ...).
const char* segmentKindName(SegmentKind kind);
/// Bilateral segments (arms, legs) exist once per side.
bool isBilateral(SegmentKind kind);
/// A segment's name (BodySegment::name): "right_" or "left_" (side -1, +1) for a bilateral kind, then its kind's name.
std::string segmentName(SegmentKind kind, int side);

/// What a clinician types, plus the simulated person's deviation from the table.
struct WearerSpec {
  double mass_kg = 75.0;    ///< (0, 300]
  double height_m = 1.78;   ///< [1.0, 2.5]
  Sex sex = Sex::Male;
  uint64_t seed = 1;        ///< of the variation draw
  double variation = 0.0;   ///< [0, 0.5]: each of mass, CoM fraction, radii x (1 + U[-v, v])
};

/// One body segment of the wearer. Principal axes in the anatomical position: x forward (antero-posterior),
/// y left (medio-lateral), z up; for the foot, whose long axis is antero-posterior, x is its long axis.
struct BodySegment {
  std::string name;          ///< "head", "right_thigh", ...
  SegmentKind kind = SegmentKind::Head;
  int side = 0;              ///< -1 right, +1 left, 0 axial
  double mass = 0.0;         ///< kg
  double length = 0.0;       ///< m, the table's length x height / reference stature
  double com_fraction = 0.0; ///< from the proximal (cranial) endpoint
  Eigen::Vector3d radius = Eigen::Vector3d::Zero();   ///< radii of gyration (x, y, z axes above), fraction of length
  Eigen::Vector3d inertia = Eigen::Vector3d::Zero();  ///< principal moments about the CoM, kg m^2: m (r L)^2
};

/// The wearer: 16 segments (head, 3 trunk parts, arms and legs per side).
struct Wearer {
  WearerSpec spec;
  std::vector<BodySegment> segments;
  int index(const std::string& name) const;  ///< -1 if absent
  double totalMass() const;
};

/// Builds the wearer (above). False and one line in *err for a spec out of range (mass, height, variation not
/// finite or out of their ranges).
bool buildWearer(const WearerSpec& spec, Wearer& out, std::string* err);

/// Where the ankle (lateral malleolus) sits above the sole standing: the table's vertical chain (head, three trunk
/// parts, thigh, shank; scaled) stacked to the stature, i.e. stature - chain (38.6 mm for the male reference,
/// 75.7 mm for the female one: the table's lengths are means of different landmarks, docs/wearer.md).
double standingAnkleHeight(const Wearer& wearer);

/// An assumption, not a table value: the ankle joint sits above a point 22 % of the foot length (HEEL-TTIP) in
/// front of the heel; the foot's CoM, at de Leva's fraction from the heel, is then in front of the ankle by
/// (com_fraction - 0.22) x length (docs/wearer.md).
inline constexpr double kHeelToAnkleFraction = 0.22;

/// The segment's CoM in the standing anatomical position (segments vertical, arms hanging at the sides, feet flat),
/// relative to the mid-point of the hip joint centres (MIDH): x forward, y left, z up. Vertical positions chain the
/// table's lengths (CoM at its fraction from the cranial / proximal end); shoulder joint centres at 0.818 x stature
/// above the floor, 0.259 x stature apart; hip joint centres 0.191 x stature apart (Winter 2009, Fig. 4.1, after
/// Drillis & Contini 1966); the foot's CoM at half the ankle height, kHeelToAnkleFraction forward as above.
Eigen::Vector3d standingSegmentCom(const Wearer& wearer, const BodySegment& segment);

/// Height above the floor of the standing wearer's whole-body CoM (the positions above on the hip height
/// standingAnkleHeight + shank + thigh). Fraction of the stature: comHeight / height.
double standingComHeight(const Wearer& wearer);

}  // namespace exoid
