#include "tests/testing/synth/room_circle.h"

#include <utility>

#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap::synth {

StatusOr<RoomCircle> RenderRoomCircle(int frames, int every) {
  if (frames < 1 || every < 1) return InvalidArgumentError("room circle: frames and every >= 1");
  SEMMAP_ASSIGN_OR_RETURN(Scene scene, MakeDefaultRoomScene(1));
  SEMMAP_ASSIGN_OR_RETURN(Renderer renderer, Renderer::Create(scene, DefaultSyntheticCamera()));
  TrajectoryOptions trajectory;
  trajectory.frames = frames;
  SEMMAP_ASSIGN_OR_RETURN(std::vector<StampedPose> poses, CircleTrajectory(scene.room, trajectory));
  RoomCircle out;
  out.camera = renderer.camera();
  for (size_t i = 0; i < poses.size(); i += static_cast<size_t>(every)) {
    out.views.push_back({renderer.Render(poses[i].T_world_camera), poses[i].T_world_camera});
  }
  return out;
}

}  // namespace semmap::synth
