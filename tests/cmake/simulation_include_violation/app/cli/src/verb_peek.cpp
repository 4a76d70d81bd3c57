// A verb that peeks at the simulated world's truth: must fail the configuration.
#include "mrsns/simulation/world.h"
