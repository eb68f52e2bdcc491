// Everything in the plant model (convenience include).
#pragma once
#include "plant/actuator.hpp"
#include "plant/bench.hpp"
#include "plant/environment.hpp"
#include "plant/fidelity.hpp"
#include "plant/params.hpp"
#include "plant/power_source.hpp"
#include "plant/quad_frame.hpp"
#include "plant/random.hpp"
#include "plant/sensors.hpp"
