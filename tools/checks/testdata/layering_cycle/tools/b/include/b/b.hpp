// fixture: b includes c, through a source file
#pragma once
