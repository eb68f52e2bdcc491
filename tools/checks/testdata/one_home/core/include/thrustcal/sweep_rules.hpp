// fixture: the home
#pragma once
constexpr unsigned kForceCentral = 65;
