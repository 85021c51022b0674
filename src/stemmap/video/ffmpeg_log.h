#pragma once

namespace stemmap {

// Sends FFmpeg's messages (warnings and errors) to our log at debug level instead of stderr, so
// stderr carries stemmap's own lines only. Safe to call from every reader and writer.
void RouteFfmpegLog();

}  // namespace stemmap
