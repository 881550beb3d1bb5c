// Whether a caller still wants a mutation to take effect. Server handlers pass one that answers
// CANCELLED or DEADLINE_EXCEEDED once the client has gone or its deadline has passed; code that
// commits something on a caller's behalf asks it right before the commit (on the storage
// writer's thread), so a call that failed for the client does not take effect after all.
// An empty CancelCheck never cancels.
#pragma once

#include <functional>

#include "common/status.h"

namespace semmap {

using CancelCheck = std::function<Status()>;

// OK for an empty check, else the check's answer.
inline Status CheckNotCancelled(const CancelCheck& check) { return check ? check() : OkStatus(); }

}  // namespace semmap
