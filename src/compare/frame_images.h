// Composite pictures of `firn compare`: frames side by side, labelled.
#pragma once

#include <firn/render.h>

#include <string>
#include <vector>

namespace firn::compare {

/// `images` (all the same height) left to right with a white gap, each with its label drawn in
/// its top-right corner.
Image sideBySide(const std::vector<Image>& images, const std::vector<std::string>& labels);

} // namespace firn::compare
