// The systems of one step, in their logical (sequential) order: the single list the scheduler
// (engine/scheduler.hpp) builds the oneTBB flow graph from. Which systems a world needs depends on
// its components (plasticity, fracture, contact, projectiles, FEM mode), never on the raw scene.
#pragma once
#include <vector>

#include "components/world_state.hpp"
#include "system.hpp"

namespace perifx::systems {

struct PipelineOptions {
  // Test oracle only: run plasticity, elastic force, fracture and damage as separate systems instead
  // of the fused bond pass (same rules, same bits; tests/systems hold them equal).
  bool separate_bond_systems = false;
};

std::vector<SystemDecl> step_pipeline(WorldState& world, PipelineOptions options = {});

}  // namespace perifx::systems
