// fixture: a includes b
#pragma once
#include "b/b.hpp"
