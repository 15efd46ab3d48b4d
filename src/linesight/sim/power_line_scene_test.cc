#include "linesight/sim/power_line_scene.h"

#include <gtest/gtest.h>

namespace linesight::sim {
namespace {

TEST(PowerLineSceneOptions, DefaultsAreValid) { EXPECT_NO_THROW(PowerLineSceneOptions().Check()); }

}  // namespace
}  // namespace linesight::sim
