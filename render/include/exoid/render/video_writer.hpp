#pragma once
// Frames -> files through ffmpeg (Debian's): raw RGB on its standard input, encoded to any of an MP4 (H.264,
// yuv420p), a GIF (one palette for the whole clip) and numbered PNG frames, in one ffmpeg process.
#include <cstdio>
#include <string>

namespace exoid::render {

struct VideoOutputs {
  std::string mp4;        ///< "" = none
  std::string gif;        ///< "" = none
  std::string png_pattern;  ///< e.g. DIR/frame_%05d.png (numbered from 0); "" = none
  int gif_width = 0;      ///< GIF scaled to this width (0: the frames' width)
};

class VideoWriter {
 public:
  VideoWriter() = default;
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Starts ffmpeg for width x height frames at fps. False with *err when no output is named.
  bool open(const VideoOutputs& outputs, int width, int height, double fps, std::string* err);
  /// One frame, rgb [height * width * 3] top row first. False when ffmpeg has stopped reading.
  bool write(const unsigned char* rgb);
  /// Ends the stream and waits for ffmpeg. False with *err when ffmpeg failed (not installed: exit 127).
  bool close(std::string* err);

 private:
  FILE* pipe_ = nullptr;
  size_t frame_bytes_ = 0;
  std::string command_;
};

}  // namespace exoid::render
