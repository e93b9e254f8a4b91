#include "exoid/tools/urdf_inertials.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "exoid/tools/csv.hpp"

namespace exoid::tools {

namespace {
// [begin, end) of the element <link name="name" ...> ... </link> (or self-closing), npos if absent.
bool findLink(const std::string& text, const std::string& name, size_t& begin, size_t& open_end, size_t& end,
              bool& self_closing) {
  for (const char q : {'"', '\''}) {
    const std::string key = std::string("name=") + q + name + q;
    size_t pos = 0;
    while ((pos = text.find("<link", pos)) != std::string::npos) {
      const size_t close = text.find('>', pos);
      if (close == std::string::npos) return false;
      const std::string tag = text.substr(pos, close - pos + 1);
      if (tag.find(key) != std::string::npos && (tag.size() > 5 && (std::isspace(static_cast<unsigned char>(tag[5])) != 0))) {
        begin = pos;
        open_end = close + 1;
        self_closing = text[close - 1] == '/';
        if (self_closing) {
          end = open_end;
        } else {
          const size_t e = text.find("</link>", open_end);
          if (e == std::string::npos) return false;
          end = e + 7;
        }
        return true;
      }
      pos = close;
    }
  }
  return false;
}

std::string stripInertials(std::string body) {
  size_t p;
  while ((p = body.find("<inertial")) != std::string::npos) {
    const size_t close = body.find('>', p);
    if (close == std::string::npos) break;
    if (body[close - 1] == '/') {
      body.erase(p, close + 1 - p);
    } else {
      const size_t e = body.find("</inertial>", close);
      if (e == std::string::npos) break;
      body.erase(p, e + 11 - p);
    }
  }
  return body;
}
}  // namespace

bool writeUrdfWithInertials(const std::string& urdf_in, const Model& model, const Eigen::VectorXd& phi,
                            const std::string& urdf_out, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  std::ifstream in(urdf_in);
  if (!in) return fail("cannot read '" + urdf_in + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // Lumped links first (their inertials go), then the bodies (replaced).
  for (const Model::Frame& f : model.frames) {
    size_t b, oe, e;
    bool sc;
    if (f.body >= 0 && findLink(text, f.name, b, oe, e, sc) && !sc)
      text = text.substr(0, oe) + stripInertials(text.substr(oe, e - oe)) + text.substr(e);
  }
  for (int body = 0; body < model.nbodies; ++body) {
    const auto p = phi.segment<kParamsPerBody>(model.bodyParamIndex(body));
    const double m = p[0];
    if (!(m > 0.0)) return fail("link '" + model.body_names[body] + "' has mass " + std::to_string(m) + " (not written)");
    const Eigen::Vector3d c = p.segment<3>(1) / m;
    Eigen::Matrix3d Io;
    Io << p[4], p[5], p[6], p[5], p[7], p[8], p[6], p[8], p[9];
    // Parallel axis: I_origin = I_com + m (|c|^2 1 - c c^T).
    const Eigen::Matrix3d Ic = Io - m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "\n    <inertial>\n      <origin xyz=\"%.17g %.17g %.17g\" rpy=\"0 0 0\"/>\n      <mass value=\"%.17g\"/>\n"
                  "      <inertia ixx=\"%.17g\" ixy=\"%.17g\" ixz=\"%.17g\" iyy=\"%.17g\" iyz=\"%.17g\" izz=\"%.17g\"/>\n    </inertial>",
                  c.x(), c.y(), c.z(), m, Ic(0, 0), Ic(0, 1), Ic(0, 2), Ic(1, 1), Ic(1, 2), Ic(2, 2));
    size_t b, oe, e;
    bool sc;
    if (!findLink(text, model.body_names[body], b, oe, e, sc)) return fail("link '" + model.body_names[body] + "' not found in '" + urdf_in + "'");
    std::string open = text.substr(b, oe - b);
    std::string inner = sc ? "" : stripInertials(text.substr(oe, e - 7 - oe));
    if (sc) open = open.substr(0, open.size() - 2) + ">";
    text = text.substr(0, b) + open + buf + inner + (sc ? "\n  " : "") + "</link>" + text.substr(e);
  }
  AtomicCsvWriter out;  // atomic text file (the writer is not CSV-specific)
  if (!out.open(urdf_out, error)) return false;
  std::fputs(text.c_str(), out.file());
  return out.commit(error);
}

}  // namespace exoid::tools
