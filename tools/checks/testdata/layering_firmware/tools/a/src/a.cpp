// fixture: a tool including an image's own header
#include "image_app.hpp"
