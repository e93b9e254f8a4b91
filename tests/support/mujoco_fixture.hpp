#pragma once
// GoogleTest fixture that loads an MJCF and turns every MuJoCo warning or error into a test failure.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <string>

namespace exoid::test {

inline std::string& mujocoMessages() {
  static std::string messages;
  return messages;
}

class MujocoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    mujocoMessages().clear();
    mju_user_warning = [](const char* msg) { mujocoMessages() += std::string("warning: ") + msg + "\n"; };
  }
  void TearDown() override {
    if (d_) mj_deleteData(d_);
    if (m_) mj_deleteModel(m_);
    mju_user_warning = nullptr;
    EXPECT_TRUE(mujocoMessages().empty()) << mujocoMessages();
  }
  /// Loads an MJCF file; fails the test with MuJoCo's message if it does not compile.
  void load(const std::string& path) {
    char err[1024] = "";
    m_ = mj_loadXML(path.c_str(), nullptr, err, sizeof(err));
    ASSERT_NE(m_, nullptr) << err;
    d_ = mj_makeData(m_);
  }
  /// Loads MJCF text through MuJoCo's virtual file system.
  void loadString(const std::string& xml) {
    mjVFS vfs;
    mj_defaultVFS(&vfs);
    ASSERT_EQ(mj_makeEmptyFileVFS(&vfs, "model.xml", static_cast<int>(xml.size())), 0);
    const int i = mj_findFileVFS(&vfs, "model.xml");
    std::copy(xml.begin(), xml.end(), static_cast<char*>(vfs.filedata[i]));
    char err[1024] = "";
    m_ = mj_loadXML("model.xml", &vfs, err, sizeof(err));
    mj_deleteVFS(&vfs);
    ASSERT_NE(m_, nullptr) << err;
    d_ = mj_makeData(m_);
  }
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
};

}  // namespace exoid::test
