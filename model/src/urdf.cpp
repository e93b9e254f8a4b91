#include "exoid/model/urdf.hpp"
#include "exoid/one_line.hpp"

#include "exoid/model/inertial.hpp"

#include <console_bridge/console.h>
#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "exoid/common/strict_number.hpp"

namespace exoid {

namespace {

/// Collects urdfdom's console messages so that a parse failure becomes one line naming the problem.
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && last_error.empty()) last_error = text;
  }
  std::string last_error;
};

bool failOneLine(std::string* error, const std::string& message) {
  if (error) *error = oneLine(message);  // tinyxml2's and urdfdom's messages quote the file
  return false;
}

Eigen::Matrix3d rotation(const urdf::Rotation& r) {
  return Eigen::Quaterniond(r.w, r.x, r.y, r.z).normalized().toRotationMatrix();
}
Eigen::Vector3d vector(const urdf::Vector3& v) { return {v.x, v.y, v.z}; }

bool finite(const urdf::Pose& p) {
  return std::isfinite(p.position.x) && std::isfinite(p.position.y) && std::isfinite(p.position.z) &&
         std::isfinite(p.rotation.x) && std::isfinite(p.rotation.y) && std::isfinite(p.rotation.z) &&
         std::isfinite(p.rotation.w);
}

/// A numeric attribute of a URDF element: how many numbers it holds and their range.
struct NumericAttribute {
  const char* element;
  const char* attribute;
  int count;
  double lo, hi;
};
constexpr double kInf = std::numeric_limits<double>::infinity();
// Every numeric attribute of the URDF specification (links and joints). urdfdom converts these leniently
// (a locale-dependent stream: "13,5" reads as 13 or 0, "abc" as 0, "1e400" as inf): check the text first.
constexpr NumericAttribute kNumericAttributes[] = {
    {"origin", "xyz", 3, -kInf, kInf},      {"origin", "rpy", 3, -kInf, kInf},
    {"mass", "value", 1, 0.0, kInf},        {"inertia", "ixx", 1, -kInf, kInf},
    {"inertia", "ixy", 1, -kInf, kInf},     {"inertia", "ixz", 1, -kInf, kInf},
    {"inertia", "iyy", 1, -kInf, kInf},     {"inertia", "iyz", 1, -kInf, kInf},
    {"inertia", "izz", 1, -kInf, kInf},     {"axis", "xyz", 3, -kInf, kInf},
    {"limit", "lower", 1, -kInf, kInf},     {"limit", "upper", 1, -kInf, kInf},
    {"limit", "effort", 1, 0.0, kInf},      {"limit", "velocity", 1, 0.0, kInf},
    {"dynamics", "damping", 1, 0.0, kInf},  {"dynamics", "friction", 1, 0.0, kInf},
    {"calibration", "rising", 1, -kInf, kInf}, {"calibration", "falling", 1, -kInf, kInf},
    {"mimic", "multiplier", 1, -kInf, kInf}, {"mimic", "offset", 1, -kInf, kInf},
    {"safety_controller", "soft_lower_limit", 1, -kInf, kInf},
    {"safety_controller", "soft_upper_limit", 1, -kInf, kInf},
    {"safety_controller", "k_position", 1, -kInf, kInf},
    {"safety_controller", "k_velocity", 1, -kInf, kInf},
    {"box", "size", 3, 0.0, kInf},          {"cylinder", "radius", 1, 0.0, kInf},
    {"cylinder", "length", 1, 0.0, kInf},   {"sphere", "radius", 1, 0.0, kInf},
    {"capsule", "radius", 1, 0.0, kInf},    {"capsule", "length", 1, 0.0, kInf},
    {"mesh", "scale", 3, -kInf, kInf},      {"color", "rgba", 4, 0.0, 1.0},
};

/// "link 'thigh' <inertial><mass value=\"13,5\"> (line 12)" for error messages.
std::string where(const tinyxml2::XMLElement* top, const tinyxml2::XMLElement* e, const char* attribute) {
  std::vector<const tinyxml2::XMLElement*> chain;
  for (const tinyxml2::XMLElement* x = e; x && x != top; x = x->Parent() ? x->Parent()->ToElement() : nullptr)
    chain.push_back(x);
  const char* name = top->Attribute("name");
  std::string s = std::string(top->Name()) + " '" + (name ? name : "?") + "' ";
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) s += "<" + std::string((*it)->Name()) + (*it == e ? "" : ">");
  return s + " " + attribute + "=" + common::quoteValue(e->Attribute(attribute)) + "> (line " +
         std::to_string(e->GetLineNum()) + ")";
}

/// Checks every numeric attribute under every <link> and <joint>: whole numbers, finite, in range.
bool checkNumbers(const tinyxml2::XMLElement* robot, std::string* error) {
  std::vector<double> values;
  for (const tinyxml2::XMLElement* top = robot->FirstChildElement(); top; top = top->NextSiblingElement()) {
    const std::string kind = top->Name();
    if (kind != "link" && kind != "joint") continue;
    std::vector<const tinyxml2::XMLElement*> todo = {top};  // depth-first, document order
    while (!todo.empty()) {
      const tinyxml2::XMLElement* e = todo.back();
      todo.pop_back();
      for (const tinyxml2::XMLElement* c = e->LastChildElement(); c; c = c->PreviousSiblingElement()) todo.push_back(c);
      for (const NumericAttribute& a : kNumericAttributes) {
        if (std::strcmp(e->Name(), a.element) != 0) continue;
        const char* text = e->Attribute(a.attribute);
        if (!text) continue;  // required attributes are urdfdom's to demand
        std::string why;
        values.resize(1);
        if (a.count == 1 ? !common::parseDouble(text, values[0], &why)
                         : !common::parseDoubleList(text, a.count, values, &why))
          return failOneLine(error, where(top, e, a.attribute) + ": " + why);
        for (double v : values)
          if (v < a.lo || v > a.hi) {
            char range[64];
            std::snprintf(range, sizeof range, a.hi == kInf ? ">= %g" : "in [%g, %g]", a.lo, a.hi);
            return failOneLine(error, where(top, e, a.attribute) + ": out of range, expected " + range);
          }
      }
      if (std::strcmp(e->Name(), "limit") == 0 && e->Attribute("lower") && e->Attribute("upper") &&
          e->DoubleAttribute("lower") > e->DoubleAttribute("upper"))
        return failOneLine(error, where(top, e, "lower") + ": lower limit above the upper limit " +
                                      common::quoteValue(e->Attribute("upper")));
    }
  }
  return true;
}

/// Parses the XML, checks its numbers (checkNumbers) and records the document order of the joints (urdfdom
/// keeps them in a name-sorted map): joint_order[name] = index in the document.
bool checkXmlAndJointOrder(const std::string& xml, std::map<std::string, int>& joint_order, std::string* error) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS)
    return failOneLine(error, std::string("malformed XML: ") + (doc.ErrorStr() ? doc.ErrorStr() : "parse error"));
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) return failOneLine(error, "no <robot> element");
  if (!checkNumbers(robot, error)) return false;
  for (const tinyxml2::XMLElement* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const char* name = j->Attribute("name");
    if (name) joint_order.emplace(name, static_cast<int>(joint_order.size()));
  }
  return true;
}

/// The tree as the walk discovers it: one body per moving joint (plus the floating base) in discovery order,
/// each with its placement in the parent body, its lumped parameters and its joint's limits.
struct WalkedTree {
  Model m;  ///< name, gravity, body_names, parent, tree_rotation/position, joint_axis, joint_names, frames
  std::vector<Vector10d> phis;  ///< [bodies] lumped parameters in the body frame
  std::vector<double> lower, upper, effort;  ///< [joints] limits (infinite / 0 when the URDF gives none)
};

/// A link on the walk: the body it belongs to and its placement in that body (body <= -2: a placeholder for
/// the body of joint -2 - body, resolved once the link's siblings are pushed).
struct WalkItem {
  urdf::LinkConstSharedPtr link;
  int body;
  Eigen::Matrix3d R;
  Eigen::Vector3d p;
};

/// Adds a link's inertial, moved into its body's frame (R, p), to the body's parameters; *own: that share.
bool lumpInertial(const urdf::Link& link, const WalkItem& it, WalkedTree& tree, Vector10d* own, std::string* error) {
  const urdf::Inertial& in = *link.inertial;
  const double vals[] = {in.mass, in.ixx, in.ixy, in.ixz, in.iyy, in.iyz, in.izz};
  for (double v : vals)
    if (!std::isfinite(v)) return failOneLine(error, "link '" + link.name + "': non-finite inertial value");
  if (!finite(in.origin)) return failOneLine(error, "link '" + link.name + "': non-finite inertial origin");
  if (in.mass < 0.0) return failOneLine(error, "link '" + link.name + "': negative mass");
  Eigen::Matrix3d Ic;
  Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const Vector10d local = paramsFromInertial(in.mass, vector(in.origin.position), rotation(in.origin.rotation), Ic);
  *own = transformParams(local, it.R, it.p);
  tree.phis[it.body] += *own;
  return true;
}

/// One child joint of the link `it`: a fixed joint continues the parent's body, a revolute or continuous
/// joint opens a new body (pushed with a placeholder index); any other type is refused.
bool pushChildJoint(const urdf::ModelInterface& urdf_model, const urdf::Joint& joint, const WalkItem& it,
                    std::vector<WalkItem>& stack, WalkedTree& tree, std::string* error) {
  Model& m = tree.m;
  urdf::LinkConstSharedPtr child = urdf_model.getLink(joint.child_link_name);
  if (!child) return failOneLine(error, "joint '" + joint.name + "': unknown child link");
  if (!finite(joint.parent_to_joint_origin_transform))
    return failOneLine(error, "joint '" + joint.name + "': non-finite origin");
  const Eigen::Matrix3d Rj = it.R * rotation(joint.parent_to_joint_origin_transform.rotation);
  const Eigen::Vector3d pj = it.p + it.R * vector(joint.parent_to_joint_origin_transform.position);
  if (joint.type == urdf::Joint::FIXED) {
    stack.push_back({child, it.body, Rj, pj});
  } else if (joint.type == urdf::Joint::REVOLUTE || joint.type == urdf::Joint::CONTINUOUS) {
    Eigen::Vector3d axis = vector(joint.axis);
    if (!axis.allFinite() || axis.norm() < 1e-12)
      return failOneLine(error, "joint '" + joint.name + "': zero or non-finite axis");
    // Placeholder index; bodies are renumbered in tree order below.
    stack.push_back({child, -2 - static_cast<int>(m.joint_names.size()), Rj, pj});
    m.joint_names.push_back(joint.name);
    m.body_names.push_back(child->name);
    m.parent.push_back(it.body);
    m.tree_rotation.push_back(Rj);
    m.tree_position.push_back(pj);
    m.joint_axis.push_back(axis.normalized());
    tree.phis.push_back(Vector10d::Zero());
    const bool limited = joint.type == urdf::Joint::REVOLUTE && joint.limits;
    tree.lower.push_back(limited ? joint.limits->lower : -std::numeric_limits<double>::infinity());
    tree.upper.push_back(limited ? joint.limits->upper : std::numeric_limits<double>::infinity());
    tree.effort.push_back(joint.limits ? joint.limits->effort : 0.0);
  } else {
    static const char* names[] = {"unknown", "revolute", "continuous", "prismatic", "floating", "planar", "fixed"};
    const int t = static_cast<int>(joint.type);
    return failOneLine(error, "joint '" + joint.name + "': type " + (t >= 0 && t <= 6 ? names[t] : "?") +
                                  " is not supported (revolute, continuous and fixed are)");
  }
  return true;
}

/// Depth-first walk from the root. For every link: a frame (its body and placement in it), its inertial lumped
/// into its body; for every moving joint a body (fixed links are lumped into their parent).
bool walkLinks(const urdf::ModelInterface& urdf_model, std::map<std::string, int>& joint_order, WalkedTree& tree,
               std::string* error) {
  Model& m = tree.m;
  const urdf::LinkConstSharedPtr root = urdf_model.getRoot();
  std::vector<WalkItem> stack;
  if (m.floating_base) {
    m.body_names.push_back(root->name);
    m.parent.push_back(-1);
    m.tree_rotation.push_back(Eigen::Matrix3d::Identity());
    m.tree_position.push_back(Eigen::Vector3d::Zero());
    m.joint_axis.push_back(Eigen::Vector3d::Zero());
    tree.phis.push_back(Vector10d::Zero());
    stack.push_back({root, 0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()});
  } else {
    stack.push_back({root, -1, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero()});
  }
  while (!stack.empty()) {
    WalkItem it = stack.back();
    stack.pop_back();
    const urdf::Link& link = *it.link;
    Model::Frame frame;
    frame.name = link.name;
    frame.body = it.body;
    frame.rotation = it.R;
    frame.position = it.p;
    if (link.inertial && it.body >= 0 && !lumpInertial(link, it, tree, &frame.phi, error)) return false;
    m.frames.push_back(frame);
    // Children in document order; pushed in reverse so that the first is visited first.
    std::vector<urdf::JointSharedPtr> joints(link.child_joints.begin(), link.child_joints.end());
    std::sort(joints.begin(), joints.end(), [&](const urdf::JointSharedPtr& a, const urdf::JointSharedPtr& b) {
      return joint_order[a->name] < joint_order[b->name];
    });
    for (auto ji = joints.rbegin(); ji != joints.rend(); ++ji)
      if (!pushChildJoint(urdf_model, **ji, it, stack, tree, error)) return false;
    // A revolute child's body index is its discovery index: resolve the placeholders just pushed.
    for (WalkItem& s : stack) {
      if (s.body <= -2) {
        const int joint = -2 - s.body;
        s.body = (m.floating_base ? 1 : 0) + joint;
        // Its own frame is the body frame.
        s.R.setIdentity();
        s.p.setZero();
      }
    }
  }
  return true;
}

/// Every link must hang from the root: urdfdom does not refuse links on a loop that the walk never reaches.
bool checkAllLinksReached(const urdf::ModelInterface& urdf_model, const Model& m, std::string* error) {
  if (m.frames.size() == urdf_model.links_.size()) return true;
  for (const auto& entry : urdf_model.links_) {
    bool reached = false;
    for (const Model::Frame& f : m.frames) reached = reached || f.name == entry.first;
    if (!reached)
      return failOneLine(error, "link '" + entry.first + "' is not connected to the root link '" +
                             urdf_model.getRoot()->name + "' (a kinematic loop?)");
  }
  return true;
}

/// Bodies were appended in the order joints were discovered (parent before child, but siblings' subtrees
/// interleaved). Returns the depth-first order following the document order of the joints: order[new] = old.
std::vector<int> depthFirstBodyOrder(const Model& m, std::map<std::string, int>& joint_order) {
  const int nb = static_cast<int>(m.body_names.size());
  std::vector<std::vector<int>> children(nb);
  std::vector<int> roots;
  for (int b = 0; b < nb; ++b) (m.parent[b] < 0 ? roots : children[m.parent[b]]).push_back(b);
  // Sibling order: document order of the joint that created the body (floating base first).
  auto key = [&](int b) {
    const int j = b - (m.floating_base ? 1 : 0);
    return j < 0 ? -1 : joint_order[m.joint_names[j]];
  };
  for (auto& c : children) std::sort(c.begin(), c.end(), [&](int a, int b) { return key(a) < key(b); });
  std::sort(roots.begin(), roots.end(), [&](int a, int b) { return key(a) < key(b); });
  std::vector<int> order;
  std::vector<int> dfs(roots.rbegin(), roots.rend());
  while (!dfs.empty()) {
    const int b = dfs.back();
    dfs.pop_back();
    order.push_back(b);
    for (auto c = children[b].rbegin(); c != children[b].rend(); ++c) dfs.push_back(*c);
  }
  return order;
}

/// The model in tree order (order[new] = old body): bodies, parameters, joints, subtrees and frames renumbered.
void assembleModel(const WalkedTree& tree, const std::vector<int>& order, Model& out) {
  const Model& m = tree.m;
  const bool floating_base = m.floating_base;
  const int nb = static_cast<int>(m.body_names.size());
  std::vector<int> new_index(nb);
  for (int i = 0; i < nb; ++i) new_index[order[i]] = i;
  Model& r = out = Model();
  r.name = m.name;
  r.floating_base = floating_base;
  r.gravity = m.gravity;
  r.nbodies = nb;
  r.njoints = static_cast<int>(m.joint_names.size());
  r.nv = (floating_base ? 6 : 0) + r.njoints;
  r.phi = Eigen::VectorXd::Zero(r.nparams());
  r.position_lower.resize(r.njoints);
  r.position_upper.resize(r.njoints);
  r.effort_limit.resize(r.njoints);
  for (int i = 0; i < nb; ++i) {
    const int o = order[i];
    r.body_names.push_back(m.body_names[o]);
    r.parent.push_back(m.parent[o] < 0 ? -1 : new_index[m.parent[o]]);
    // Placement relative to the parent body frame: stored as absolute-in-parent during the walk.
    r.tree_rotation.push_back(m.tree_rotation[o]);
    r.tree_position.push_back(m.tree_position[o]);
    r.joint_axis.push_back(m.joint_axis[o]);
    r.phi.segment<kParamsPerBody>(r.bodyParamIndex(i)) = tree.phis[o];
    const int old_joint = o - (floating_base ? 1 : 0);
    if (old_joint >= 0) {
      const int j = r.jointOfBody(i);
      r.joint_names.resize(r.njoints);
      r.joint_names[j] = m.joint_names[old_joint];
      r.position_lower[j] = tree.lower[old_joint];
      r.position_upper[j] = tree.upper[old_joint];
      r.effort_limit[j] = tree.effort[old_joint];
    }
  }
  r.joint_body.resize(r.njoints);
  r.joint_type.assign(r.njoints, JointType::Revolute);
  for (int j = 0; j < r.njoints; ++j) r.joint_body[j] = j + (floating_base ? 1 : 0);
  r.subtree.assign(nb, {});
  for (int b = nb - 1; b >= 0; --b) {
    r.subtree[b].insert(r.subtree[b].begin(), b);
    if (r.parent[b] >= 0) {
      auto& ps = r.subtree[r.parent[b]];
      ps.insert(ps.end(), r.subtree[b].begin(), r.subtree[b].end());
    }
  }
  for (auto& s : r.subtree) std::sort(s.begin(), s.end());
  for (Model::Frame f : m.frames) {
    if (f.body >= 0) f.body = new_index[f.body];
    r.frames.push_back(f);
  }
}

}  // namespace

bool buildModelFromUrdfFile(const std::string& path, bool floating_base, Model& model, std::string* error,
                            double gravity_magnitude) {
  std::ifstream in(path);
  if (!in) return failOneLine(error, "cannot read URDF file '" + path + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string err;
  if (!buildModelFromUrdfString(ss.str(), floating_base, model, &err, gravity_magnitude))
    return failOneLine(error, "URDF '" + path + "': " + err);
  return true;
}

bool buildModelFromUrdfString(const std::string& xml, bool floating_base, Model& out, std::string* error,
                              double gravity_magnitude) {
  if (!std::isfinite(gravity_magnitude) || gravity_magnitude < 0.0)
    return failOneLine(error, "gravity must be finite and non-negative");
  std::map<std::string, int> joint_order;
  if (!checkXmlAndJointOrder(xml, joint_order, error)) return false;
  CaptureHandler capture;
  console_bridge::useOutputHandler(&capture);
  urdf::ModelInterfaceSharedPtr urdf_model;
  try {
    urdf_model = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    capture.last_error = e.what();
  }
  console_bridge::restorePreviousOutputHandler();
  if (!urdf_model)
    return failOneLine(error, capture.last_error.empty() ? "urdfdom could not parse the robot" : capture.last_error);
  // urdfdom accepts a kinematic loop detached from the root; its links then own each other (child_links are
  // shared pointers) and would leak. Break those references whatever this function returns.
  struct ReleaseLinks {
    const urdf::ModelInterface& model;
    ~ReleaseLinks() {
      for (const auto& entry : model.links_) entry.second->child_links.clear();
    }
  } release_links{*urdf_model};
  if (!urdf_model->getRoot()) return failOneLine(error, "no root link");

  WalkedTree tree;
  tree.m.name = urdf_model->getName();
  tree.m.floating_base = floating_base;
  tree.m.gravity = Eigen::Vector3d(0.0, 0.0, -gravity_magnitude);
  if (!walkLinks(*urdf_model, joint_order, tree, error)) return false;
  if (!checkAllLinksReached(*urdf_model, tree.m, error)) return false;
  if (tree.m.body_names.empty())
    return failOneLine(error, "no moving link: the root is fixed to the world and no revolute or continuous joint "
                              "follows it (a floating base would move)");
  assembleModel(tree, depthFirstBodyOrder(tree.m, joint_order), out);
  return true;
}

}  // namespace exoid
