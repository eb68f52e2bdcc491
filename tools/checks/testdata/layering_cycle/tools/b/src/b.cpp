#include "c/c.hpp"
