// Strict numbers in URDF files: every numeric attribute must be whole, finite numbers in range; anything else
// is one line naming the link or joint, the element, the attribute, the value and the line. urdfdom alone
// read <mass value="13,5"/> (and abc, nan, 1e400, empty) as 0 kg or garbage without a word.
#include <gtest/gtest.h>

#include <fstream>

#include "exoid/model/urdf.hpp"
#include "support/paths.hpp"

namespace exoid {
namespace {

// Two links and a revolute joint; every numeric attribute of the loader's input appears once.
std::string urdf(const std::string& mass = "2", const std::string& ixx = "0.1", const std::string& com = "0 0 0.1",
                 const std::string& axis = "0 1 0", const std::string& effort = "50",
                 const std::string& lower = "-1", const std::string& rgba = "1 0 0 1") {
  return "<robot name='r'>\n"
         "<link name='base'><inertial><origin xyz='" + com + "' rpy='0 0 0'/><mass value='" + mass + "'/>\n"
         "<inertia ixx='" + ixx + "' iyy='0.2' izz='0.3' ixy='0' ixz='0' iyz='0'/></inertial>\n"
         "<visual><geometry><box size='0.1 0.1 0.1'/></geometry><material name='m'><color rgba='" + rgba +
         "'/></material></visual></link>\n"
         "<link name='leg'><inertial><mass value='1'/><inertia ixx='1' iyy='1' izz='1' ixy='0' ixz='0' iyz='0'/>"
         "</inertial></link>\n"
         "<joint name='hip' type='revolute'><parent link='base'/><child link='leg'/><origin xyz='0 0 -0.1'/>\n"
         "<axis xyz='" + axis + "'/><limit lower='" + lower + "' upper='1' effort='" + effort +
         "' velocity='3'/></joint>\n</robot>\n";
}

std::string loadError(const std::string& xml) {
  Model m;
  std::string err;
  EXPECT_FALSE(buildModelFromUrdfString(xml, true, m, &err));
  EXPECT_EQ(err.find('\n'), std::string::npos) << err;
  return err;
}

TEST(UrdfNumbers, ValidFileLoadsWithTheWrittenValues) {
  Model m;
  std::string err;
  ASSERT_TRUE(buildModelFromUrdfString(urdf("+2.5", "1e-320", " 0  0 0.1 "), true, m, &err)) << err;
  EXPECT_EQ(m.phi[0], 2.5);
  EXPECT_DOUBLE_EQ(m.phi[3], 2.5 * 0.1);  // m * c_z
}

TEST(UrdfNumbers, MassThatIsNotOneFiniteNumberIsRefused) {
  const std::pair<std::string, std::string> cases[] = {
      {"13,5", "not a number"}, {"abc", "not a number"}, {"nan", "not finite"}, {"inf", "not finite"},
      {"1e400", "too large for a double"}, {"", "empty"}, {"1 2", "not a number"}, {"-1", "out of range, expected >= 0"},
      {"0x10", "not a number"}};
  for (const auto& [value, reason] : cases) {
    const std::string err = loadError(urdf(value));
    EXPECT_NE(err.find("link 'base' <inertial><mass value='" + value + "'> (line 2): " + reason), std::string::npos)
        << value << ": " << err;
  }
}

TEST(UrdfNumbers, EveryKindOfAttributeIsChecked) {
  struct Case {
    std::string xml, needle;
  };
  const Case cases[] = {
      {urdf("2", "0.1,0"), "link 'base' <inertial><inertia ixx='0.1,0'> (line 3): not a number"},
      {urdf("2", "0.1", "0 nan 0.1"), "link 'base' <inertial><origin xyz='0 nan 0.1'> (line 2): number 2 'nan': not finite"},
      {urdf("2", "0.1", "0 0"), "<origin xyz='0 0'> (line 2): expected 3 numbers, got 2"},
      {urdf("2", "0.1", "0 0 0.1", "0 1e999 0"), "joint 'hip' <axis xyz='0 1e999 0'> (line 7): number 2 '1e999': too large"},
      {urdf("2", "0.1", "0 0 0.1", "0 1 0", "-5"), "joint 'hip' <limit effort='-5'> (line 7): out of range, expected >= 0"},
      {urdf("2", "0.1", "0 0 0.1", "0 1 0", "50", "2"), "joint 'hip' <limit lower='2'> (line 7): lower limit above the upper limit '1'"},
      {urdf("2", "0.1", "0 0 0.1", "0 1 0", "50", "-1", "1 0 0 2"), "<visual><material><color rgba='1 0 0 2'> (line 4): out of range, expected in [0, 1]"},
  };
  for (const Case& c : cases) {
    const std::string err = loadError(c.xml);
    EXPECT_NE(err.find(c.needle), std::string::npos) << err;
  }
}

TEST(UrdfNumbers, FileErrorsNameTheFile) {
  const std::string path = ::testing::TempDir() + "/exoid_urdf_numbers_" + std::to_string(::getpid()) + ".urdf";
  std::ofstream(path) << urdf("13,5");
  Model m;
  std::string err;
  EXPECT_FALSE(buildModelFromUrdfFile(path, true, m, &err));
  EXPECT_EQ(err.rfind("URDF '" + path + "': link 'base' <inertial><mass value='13,5'>", 0), 0u) << err;
  std::remove(path.c_str());
}

TEST(UrdfNumbers, ShippedModelsPass) {
  for (const std::string& path : {test::configPath("exo.urdf"), test::dataPath("kuka_lwr4/kuka_lwr4.urdf")}) {
    Model m;
    std::string err;
    EXPECT_TRUE(buildModelFromUrdfFile(path, false, m, &err)) << path << ": " << err;
  }
}

}  // namespace
}  // namespace exoid
