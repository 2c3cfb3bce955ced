// Rendered frames of two runs against each other: difference images and side-by-side strips.
#include <firn/compare.h>

#include "compare/frame_images.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

namespace firn {
namespace {

void requireSameSize(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) {
        throw std::invalid_argument("frames of different sizes: " + std::to_string(a.width) + "x" +
                                    std::to_string(a.height) + " and " + std::to_string(b.width) +
                                    "x" + std::to_string(b.height));
    }
}

int channelDifference(const Image& a, const Image& b, int x, int y) {
    const std::uint8_t* p = a.pixel(x, y);
    const std::uint8_t* q = b.pixel(x, y);
    int d = 0;
    for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(p[k]) - int(q[k])));
    return d;
}

} // namespace

Image differenceImage(const Image& a, const Image& b) {
    requireSameSize(a, b);
    Image out(a.width, a.height);
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            const int d = channelDifference(a, b, x, y);
            if (d == 0) continue; // stays black
            // From dark red at a one-level difference to pale yellow at 64 levels and more.
            const float t = std::min(1.f, d / 64.f);
            out.set(x, y, colorMap(ColorBy::Eta, 0.3f + 0.7f * t));
        }
    }
    return out;
}

FrameComparison compareImages(const Image& a, const Image& b) {
    requireSameSize(a, b);
    FrameComparison c;
    long changed = 0;
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            const int d = channelDifference(a, b, x, y);
            c.maxChannelDifference = std::max(c.maxChannelDifference, d);
            if (d > kPixelThreshold) ++changed;
        }
    }
    const long pixels = long(a.width) * a.height;
    c.changedFraction = pixels > 0 ? double(changed) / pixels : 0.0;
    return c;
}

namespace compare {

Image sideBySide(const std::vector<Image>& images, const std::vector<std::string>& labels) {
    const int gap = 6;
    int width = gap * int(images.size() - 1), height = 0;
    for (const Image& image : images) {
        width += image.width;
        height = std::max(height, image.height);
    }
    Image out(width, height, {255, 255, 255});
    int left = 0;
    for (std::size_t i = 0; i < images.size(); ++i) {
        const Image& image = images[i];
        for (int y = 0; y < image.height; ++y)
            std::copy_n(image.pixel(0, y), 3 * image.width, out.pixel(left, y));
        if (i < labels.size()) {
            const int scale = image.width >= 640 ? 2 : 1;
            const int textWidth = int(labels[i].size()) * 6 * scale;
            drawText(out, left + image.width - textWidth - 8 * scale, 8 * scale, labels[i],
                     {0.8f, 0.1f, 0.1f}, scale);
        }
        left += image.width + gap;
    }
    return out;
}

} // namespace compare
} // namespace firn
