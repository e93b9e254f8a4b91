// URDF inputs found by fuzz_urdf (fuzz/, docs/testing.md), each once a wrong result or a sanitizer report.
#include <gtest/gtest.h>

#include "exoid/model/urdf.hpp"

namespace exoid {
namespace {

// Two links that are each other's parent: urdfdom finds the one root (base) and accepts the file, the walk
// from the root never reaches the loop, and the model silently lacked two links; the loop's links also held
// each other alive (a leak the sanitizer build reports).
const char* kDetachedLoop = R"(<?xml version="1.0"?>
<robot name="loop">
  <link name="base"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="arm"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="loop_a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="loop_b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/></joint>
  <joint name="a_to_b" type="continuous"><parent link="loop_a"/><child link="loop_b"/><axis xyz="0 0 1"/></joint>
  <joint name="b_to_a" type="continuous"><parent link="loop_b"/><child link="loop_a"/><axis xyz="0 0 1"/></joint>
</robot>)";

TEST(UrdfRegressions, LinksOnALoopDetachedFromTheRootAreRefused) {
  for (const bool floating : {false, true}) {
    Model model;
    std::string err;
    EXPECT_FALSE(buildModelFromUrdfString(kDetachedLoop, floating, model, &err)) << "floating " << floating;
    EXPECT_NE(err.find("link 'loop_a' is not connected to the root link 'base'"), std::string::npos) << err;
    EXPECT_EQ(err.find('\n'), std::string::npos) << err;
  }
}

// tinyxml2's message for a misplaced declaration quotes its text, line breaks included: the error
// was several lines. Control characters are now escaped.
TEST(UrdfRegressions, MalformedXmlErrorIsOneLine) {
  Model model;
  std::string err;
  EXPECT_FALSE(buildModelFromUrdfString("<robot name=\"r\">\n<?xml version=\n  1 ?>\n</robot>\n", false, model, &err));
  EXPECT_NE(err.find("malformed XML"), std::string::npos) << err;
  EXPECT_NE(err.find("\\n"), std::string::npos) << "the line break shown escaped: " << err;
  EXPECT_EQ(err.find('\n'), std::string::npos) << err;
}

}  // namespace
}  // namespace exoid
