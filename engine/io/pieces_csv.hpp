// pieces.csv: the per-piece motion of a run (engine/animation.hpp), one row per piece and frame.
#pragma once
#include <filesystem>

#include "animation.hpp"

namespace perifx::io {

// Header: piece,frame,time,birth_frame,parent,particles,mass,cx,cy,cz,tx,ty,tz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz
// (SI units; c: centre of mass; t and q (unit quaternion, w ≥ 0): the best-fit rigid motion from the
// reference pose, y ≈ R(q) X + t; v: velocity of the centre of mass; w: angular velocity; parent
// empty for pieces of the first frame). Rows by frame, then piece id. Numbers are the shortest text
// that reads back to the same double. Written atomically.
void write_pieces_csv(const std::filesystem::path& file, const AnimationHistory& history);

}  // namespace perifx::io
