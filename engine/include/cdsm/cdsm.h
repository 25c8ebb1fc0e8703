// Clustered deep shadow maps — the public API (umbrella header).
#pragma once

#include "cdsm/error.h"
#include "cdsm/image.h"
#include "cdsm/math.h"
#include "cdsm/procedural.h"
#include "cdsm/renderer.h"
#include "cdsm/scene.h"
#include "cdsm/scene_io.h"
#include "cdsm/shadow_system.h"
