#pragma once

#include <string>
#include <utility>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/frontend.h"
#include "stemmap/video/video_reader.h"

namespace stemmap::track {

// What a video must be for tracking, and what to say when it is not: checks on the container
// and on how the front end saw the picture move.

// Throws InputError when the frames are too small to measure trunks in (under 320x180 px).
void CheckFrameSize(const VideoInfo& info);

// Why the picture's motion cannot be a turn of the arm (a still camera, a picture turned 90°);
// empty when it can.
std::string MotionProblem(const FrontendResult& f, const PinholeCamera& camera);

// Whether the frames end well before the time the file's header gives (a copy cut short).
bool EndsEarly(const FrontendResult& f);

// What the file itself lacks, to add to a failure's message ("; the file is ..."): the part a
// cut-short copy lost, and where the decoder met damaged data. Empty for a whole, clean file.
std::string DamageNote(const FrontendResult& f);

// Fills the turn increments lost (NaN) where damaged or missing frames broke the tracks between
// two keyframes at most `max_gap_s` apart, with the median turn rate of the tracked increments
// nearby times the time between them. Returns the bridged stretches (s).
std::vector<std::pair<double, double>> BridgeDamagedGaps(const FrontendResult& f, double max_gap_s,
                                                         std::vector<double>* inc);

}  // namespace stemmap::track
