// fixture: c includes a back: a -> b -> c -> a
#pragma once
#include "a/a.hpp"
