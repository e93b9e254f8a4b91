#pragma once
// A headless OpenGL context for MuJoCo's renderer: EGL on Mesa's surfaceless platform (no X server, no window;
// llvmpipe on a machine without a GPU). MuJoCo's own loader (mjr_makeContext) then finds the GL functions through
// libEGL. docs/render.md says why EGL rather than Xvfb + GLFW or OSMesa.
#include <string>

namespace exoid::render {

/// Owns an EGL display and an OpenGL context made current on the calling thread (no surface: MuJoCo renders
/// into its own offscreen framebuffer). Move-free: create one per thread that renders.
class EglContext {
 public:
  EglContext() = default;
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  /// Initialises EGL (surfaceless platform, else the default display), creates a desktop OpenGL context and
  /// makes it current. False and one line in *err when no EGL/OpenGL implementation is usable.
  bool create(std::string* err);
  bool current() const { return context_ != nullptr; }

 private:
  void* display_ = nullptr;  // EGLDisplay
  void* context_ = nullptr;  // EGLContext
};

}  // namespace exoid::render
