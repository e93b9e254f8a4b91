#include "mjcf_check.hpp"

#include <tinyxml2.h>

#include <cstring>
#include <vector>

#include "exoid/common/strict_number.hpp"

namespace exoid::sim {

namespace {
// Attributes holding numbers in MuJoCo 2.2's MJCF schema (elements and defaults alike).
constexpr const char* kNumeric[] = {
    "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler", "axis", "mass", "diaginertia", "fullinertia", "size",
    "fromto", "range", "ctrlrange", "forcerange", "gear", "damping", "frictionloss", "armature", "stiffness",
    "springref", "springdamper", "ref", "friction", "solref", "solimp", "solreflimit", "solimplimit",
    "solreffriction", "solimpfriction", "margin", "gap", "density", "timestep", "gravity", "wind", "magnetic",
    "viscosity", "impratio", "tolerance", "noslip_tolerance", "mpr_tolerance", "o_margin", "o_solref", "o_solimp",
    "rgba", "dir", "diffuse", "ambient", "specular", "attenuation", "cutoff", "exponent", "fovy", "ipd", "kp",
    "kv", "gainprm", "biasprm", "dynprm", "lengthrange", "polycoef", "width", "refpos", "refquat", "scale",
    "condim", "contype", "conaffinity", "group", "priority", "iterations", "noslip_iterations", "mpr_iterations",
    "user", "cranklength", "ctrl", "qpos", "qvel", "act", "mocap_pos", "mocap_quat", "reflectance",
    "shininess", "emission", "texrepeat", "random", "rgb1", "rgb2", "markrgb", "height", "zfar",
    "znear", "extent", "center", "meaninertia", "actdim", "noise"};

bool numeric(const char* name) {
  for (const char* n : kNumeric)
    if (std::strcmp(n, name) == 0) return true;
  return false;
}
}  // namespace

bool checkMjcfNumbers(const std::string& path, std::string* err) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) return true;  // MuJoCo reports it, naming the file
  // Depth-first in document order, so that the first bad attribute in the file is the one reported.
  std::vector<const tinyxml2::XMLElement*> todo;
  for (const tinyxml2::XMLElement* e = doc.LastChildElement(); e; e = e->PreviousSiblingElement()) todo.push_back(e);
  std::vector<double> values;
  while (!todo.empty()) {
    const tinyxml2::XMLElement* e = todo.back();
    todo.pop_back();
    for (const tinyxml2::XMLElement* c = e->LastChildElement(); c; c = c->PreviousSiblingElement()) todo.push_back(c);
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
      if (!numeric(a->Name())) continue;
      std::string why;
      if (std::strcmp(a->Name(), "user") == 0 && !*a->Value()) continue;  // an empty user array is allowed
      const std::string value = a->Value();
      if (value.find_first_of(" \t\r\n") == std::string::npos) {  // one number: the plain reason
        double v = 0.0;
        if (common::parseDouble(value, v, &why)) continue;
      } else if (common::parseDoubleList(value, -1, values, &why)) {
        if (!values.empty()) continue;
        why = "empty, expected numbers";
      }
      // Name the nearest named element (body, joint, geom...) so that the line is findable by name as well.
      std::string owner;
      for (const tinyxml2::XMLNode* n = e; n && n->ToElement(); n = n->Parent()) {
        const tinyxml2::XMLElement* x = n->ToElement();
        if (x->Attribute("name")) {
          owner = std::string(x->Name()) + " '" + x->Attribute("name") + "' ";
          break;
        }
      }
      if (err)
        *err = path + ": " + owner + "<" + e->Name() + " " + a->Name() + "=" + common::quoteValue(a->Value()) +
               "> (line " + std::to_string(e->GetLineNum()) + "): " + why;
      return false;
    }
  }
  return true;
}

}  // namespace exoid::sim
