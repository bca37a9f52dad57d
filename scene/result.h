#pragma once
// Errors as values: Result<T>, Status and ErrorCode are defined in base/result.h, the bottom module, so that modules
// below the scene types (base/) return them too. The scene's headers and their users include it through here.
#include "base/result.h"
