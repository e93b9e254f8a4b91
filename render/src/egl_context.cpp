#include "exoid/render/egl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstdio>

namespace exoid::render {

namespace {
bool fail(std::string* err, const char* what) {
  if (err) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "EGL: %s (error 0x%x); is Mesa's libegl1/libegl-mesa0 installed?", what, eglGetError());
    *err = buf;
  }
  return false;
}

// Mesa's surfaceless platform needs no display server; without the extension, the default display.
EGLDisplay openDisplay() {
  auto get_platform = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform) {
    EGLDisplay d = get_platform(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY) return d;
  }
  return eglGetDisplay(EGL_DEFAULT_DISPLAY);
}
}  // namespace

bool EglContext::create(std::string* err) {
  if (context_) return true;
  EGLDisplay dpy = openDisplay();
  EGLint major = 0, minor = 0;
  if (dpy == EGL_NO_DISPLAY || !eglInitialize(dpy, &major, &minor)) return fail(err, "no display could be initialised");
  display_ = dpy;
  const EGLint attributes[] = {EGL_RED_SIZE,     8, EGL_GREEN_SIZE,   8,  EGL_BLUE_SIZE,       8, EGL_ALPHA_SIZE, 8,
                               EGL_DEPTH_SIZE,  24, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                               EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config;
  EGLint n = 0;
  if (!eglChooseConfig(dpy, attributes, &config, 1, &n) || n < 1) return fail(err, "no RGBA8 + depth24 OpenGL config");
  if (!eglBindAPI(EGL_OPENGL_API)) return fail(err, "desktop OpenGL not available");
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, nullptr);
  if (ctx == EGL_NO_CONTEXT) return fail(err, "cannot create an OpenGL context");
  context_ = ctx;
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) return fail(err, "cannot make the context current");
  return true;
}

EglContext::~EglContext() {
  if (!display_) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_) eglDestroyContext(display_, context_);
  eglTerminate(display_);
}

}  // namespace exoid::render
