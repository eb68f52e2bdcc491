// fixture: a copy that could drift
#pragma once
constexpr unsigned kForceCentral = 65;
