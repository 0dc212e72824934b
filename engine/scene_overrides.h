#pragma once
// The CLI's `--set a.b[i].c=value` on a parsed scene document, before it is read, so overrides pass
// the same checks as the file. Loader side only.
#include <string>

#include <toml++/toml.h>

namespace dem::loader {

/// Applies "a.b[i].c=value": the value is parsed as TOML (a bare word becomes a string). Throws
/// InputError (file "--set") for a malformed option or a path that leads nowhere.
void apply_override(toml::table& root, const std::string& option);

}  // namespace dem::loader
