#include "exoid/render/video_writer.hpp"

#include <csignal>
#include <sys/wait.h>

namespace exoid::render {

namespace {
std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}
}  // namespace

bool VideoWriter::open(const VideoOutputs& o, int width, int height, double fps, std::string* err) {
  if (o.mp4.empty() && o.gif.empty() && o.png_pattern.empty()) {
    if (err) *err = "no output to write";
    return false;
  }
  char head[256];
  std::snprintf(head, sizeof head, "ffmpeg -nostdin -hide_banner -loglevel error -y -f rawvideo -pix_fmt rgb24 -s %dx%d "
                "-framerate %.6g -i -", width, height, fps);
  command_ = head;
  // yuv420p: the H.264 profile every player decodes (needs even sizes: the CLI asks for them).
  if (!o.mp4.empty()) command_ += " -c:v libx264 -preset veryfast -crf 23 -pix_fmt yuv420p " + shellQuote(o.mp4);
  if (!o.gif.empty()) {
    const std::string scale = o.gif_width > 0 ? "scale=" + std::to_string(o.gif_width) + ":-1:flags=lanczos," : "";
    command_ += " -filter_complex " +
                shellQuote("[0:v]" + scale + "split[a][b];[a]palettegen=max_colors=128[p];[b][p]paletteuse=dither=bayer") +
                " -loop 0 " + shellQuote(o.gif);
  }
  if (!o.png_pattern.empty()) command_ += " -start_number 0 " + shellQuote(o.png_pattern);
  std::signal(SIGPIPE, SIG_IGN);  // ffmpeg gone: write() reports it instead of killing this process
  pipe_ = popen(command_.c_str(), "w");
  if (!pipe_) {
    if (err) *err = "cannot start ffmpeg";
    return false;
  }
  frame_bytes_ = static_cast<size_t>(width) * static_cast<size_t>(height) * 3;
  return true;
}

bool VideoWriter::write(const unsigned char* rgb) {
  return pipe_ && std::fwrite(rgb, 1, frame_bytes_, pipe_) == frame_bytes_;
}

bool VideoWriter::close(std::string* err) {
  if (!pipe_) return true;
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status != 0) {
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (err)
      *err = code == 127 ? "ffmpeg not found (Debian: apt-get install ffmpeg)"
                         : "ffmpeg failed (exit " + std::to_string(code) + "): " + command_;
    return false;
  }
  return true;
}

VideoWriter::~VideoWriter() {
  if (pipe_) pclose(pipe_);
}

}  // namespace exoid::render
