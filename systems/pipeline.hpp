// The systems of one step, in their logical (sequential) order: the single list the scheduler
// (engine/scheduler.hpp) builds the oneTBB flow graph from. Which systems a world needs depends on
// its components (plasticity, fracture, contact, projectiles, FEM mode), never on the raw scene.
#pragma once
#include <functional>
#include <vector>

#include "components/world_state.hpp"
#include "system.hpp"

namespace perifx::systems {

struct PipelineOptions {
  // Test oracle only: run plasticity, elastic force, fracture and damage as separate systems instead
  // of the fused bond pass (same rules, same bits; tests/systems hold them equal).
  bool separate_bond_systems = false;
  // Distributed runs (engine/distributed/local_world.hpp): the halo exchanges, run as systems right
  // after the values they carry are computed. Null in one process.
  struct Halo {
    std::function<void()> motion;      // after the drift and colliders: ghosts' position, velocity
    std::function<void()> dilatation;  // after the dilatation pass: ghosts' θ and P
    std::function<void()> threshold;   // after the fracture threshold: ghosts' break extension
    // In projectile_contact: this rank's projectile contacts → every rank's, in rank order.
    std::function<void(std::vector<double>&)> projectile_contacts;
  };
  const Halo* halo = nullptr;
  // False for a world without the embedded tet mesh (a distributed run's local world): its systems
  // (crack faces, mesh split, rotations, vertices) are left out.
  bool embedded_mesh = true;
};

std::vector<SystemDecl> step_pipeline(WorldState& world, PipelineOptions options = {});

}  // namespace perifx::systems
