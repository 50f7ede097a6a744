// The fitted effects' own curves for `auger report`, each the model before the fit against the
// model after it, over the speeds the log covers: the force against speed (the resistance of
// eq. (6) plus the effects' body forces, per DOF), the steady speed against screw speed (every
// effect that changes the motion: traction, dead band, saturation, friction, drag), each screw's
// drive force against its own speed (a one-screw effect apart), screw blocking against one screw's
// speed near zero (not as a friction of the body's speed), the drive
// force after a step of the screw speeds (effects with a state: a lag or a dead time) and the IMU
// heading offset over time (sensor effects). A curve that the fit leaves unchanged is not drawn.
#pragma once

#include <vector>

#include "report_charts.hpp"
#include "workbench.hpp"

namespace auger::wb {

std::vector<Chart> effect_curves(const Model& before, const Model& after, const Dataset& data);

}  // namespace auger::wb
