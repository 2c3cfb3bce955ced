// Images for review renders: PNG files (libpng's simplified API), colour maps, a bitmap font for
// labels, colour bars and contact sheets. Nothing here knows about OpenVDB.
#include <firn/errors.h>
#include <firn/render.h>

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace firn {
namespace {

struct ColorStop {
    float t;
    Rgb colour;
};

// Samples of matplotlib's viridis and magma (perceptually uniform; van der Walt & Smith 2015)
// and of Moreland's cool-warm diverging map, interpolated linearly in between.
const ColorStop kViridis[] = {{0.00f, {0.267f, 0.005f, 0.329f}},
                              {0.25f, {0.229f, 0.322f, 0.545f}},
                              {0.50f, {0.128f, 0.567f, 0.551f}},
                              {0.75f, {0.369f, 0.789f, 0.383f}},
                              {1.00f, {0.993f, 0.906f, 0.144f}}};
const ColorStop kMagma[] = {{0.00f, {0.001f, 0.000f, 0.014f}},
                            {0.25f, {0.316f, 0.072f, 0.485f}},
                            {0.50f, {0.716f, 0.215f, 0.475f}},
                            {0.75f, {0.987f, 0.535f, 0.382f}},
                            {1.00f, {0.987f, 0.991f, 0.750f}}};
const ColorStop kCoolWarm[] = {{0.00f, {0.230f, 0.299f, 0.754f}},
                               {0.50f, {0.865f, 0.865f, 0.865f}},
                               {1.00f, {0.706f, 0.016f, 0.150f}}};

template <std::size_t N> Rgb interpolate(const ColorStop (&stops)[N], float t) {
    t = std::clamp(t == t ? t : 0.f, 0.f, 1.f);
    for (std::size_t i = 1; i < N; ++i) {
        if (t <= stops[i].t) {
            const float w = (t - stops[i - 1].t) / (stops[i].t - stops[i - 1].t);
            Rgb c;
            for (int k = 0; k < 3; ++k)
                c[k] = stops[i - 1].colour[k] + w * (stops[i].colour[k] - stops[i - 1].colour[k]);
            return c;
        }
    }
    return stops[N - 1].colour;
}

std::uint8_t toByte(float v) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f));
}

// A 5x7 bitmap font: 7 rows per glyph, bit 4 the leftmost column.
struct Glyph {
    char c;
    std::uint8_t rows[7];
};
const Glyph kFont[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'a', {0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F}},
    {'b', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E}},
    {'c', {0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E}},
    {'d', {0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F}},
    {'e', {0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E}},
    {'f', {0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08}},
    {'g', {0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
    {'h', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11}},
    {'i', {0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E}},
    {'j', {0x02, 0x00, 0x06, 0x02, 0x02, 0x12, 0x0C}},
    {'k', {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12}},
    {'l', {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'m', {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11}},
    {'n', {0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11}},
    {'o', {0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E}},
    {'p', {0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10}},
    {'q', {0x00, 0x00, 0x0D, 0x13, 0x0F, 0x01, 0x01}},
    {'r', {0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10}},
    {'s', {0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E}},
    {'t', {0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06}},
    {'u', {0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D}},
    {'v', {0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'w', {0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A}},
    {'x', {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11}},
    {'y', {0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
    {'z', {0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}},
    {'=', {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
    {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
    {'%', {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03}},
    {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
};

const Glyph* glyphOf(char c) {
    const char lower = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (const Glyph& g : kFont) {
        if (g.c == lower) return &g;
    }
    return nullptr;
}

const char* quantityLabel(ColorBy quantity) {
    switch (quantity) {
    case ColorBy::Density:
        return "density (kg/m3)";
    case ColorBy::Speed:
        return "speed (m/s)";
    case ColorBy::Failed:
        return "failed fraction";
    case ColorBy::Eta:
        return "eta";
    }
    return "";
}

std::string shortNumber(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", value);
    return text;
}

} // namespace

Image::Image(int w, int h, std::array<std::uint8_t, 3> fill)
    : width(w)
    , height(h)
    , rgb(std::size_t(w) * h * 3) {
    for (std::size_t i = 0; i < rgb.size(); i += 3) std::memcpy(&rgb[i], fill.data(), 3);
}

void Image::set(int x, int y, const Rgb& colour) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    std::uint8_t* p = pixel(x, y);
    for (int k = 0; k < 3; ++k) p[k] = toByte(colour[k]);
}

void writePng(const std::string& path, const Image& image) {
    png_image png;
    std::memset(&png, 0, sizeof png);
    png.version = PNG_IMAGE_VERSION;
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    const std::string tmp = path + ".tmp";
    errno = 0;
    if (!png_image_write_to_file(&png, tmp.c_str(), 0, image.rgb.data(), 0, nullptr)) {
        const std::string why = errno ? std::strerror(errno) : png.message;
        std::remove(tmp.c_str());
        throw IoError(path + ": cannot write PNG: " + why);
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const int errnum = errno;
        std::remove(tmp.c_str());
        throw IoError(path + ": cannot write PNG: " + std::strerror(errnum));
    }
}

Image readPng(const std::string& path) {
    png_image png;
    std::memset(&png, 0, sizeof png);
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str())) {
        throw IoError(path + ": cannot read PNG: " + png.message);
    }
    png.format = PNG_FORMAT_RGB;
    Image image(static_cast<int>(png.width), static_cast<int>(png.height));
    if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr)) {
        png_image_free(&png);
        throw IoError(path + ": cannot read PNG: " + png.message);
    }
    return image;
}

Rgb colorMap(ColorBy quantity, float t) {
    switch (quantity) {
    case ColorBy::Failed:
        return interpolate(kCoolWarm, t);
    case ColorBy::Eta:
        return interpolate(kMagma, t);
    case ColorBy::Density:
    case ColorBy::Speed:
        break;
    }
    return interpolate(kViridis, t);
}

void drawText(Image& image, int x, int y, const std::string& text, const Rgb& colour, int scale) {
    for (std::size_t i = 0; i < text.size(); ++i) {
        const Glyph* g = glyphOf(text[i]);
        if (!g) continue;
        const int left = x + static_cast<int>(i) * 6 * scale;
        for (int row = 0; row < 7; ++row) {
            for (int col = 0; col < 5; ++col) {
                if (!(g->rows[row] & (0x10 >> col))) continue;
                for (int sy = 0; sy < scale; ++sy)
                    for (int sx = 0; sx < scale; ++sx)
                        image.set(left + col * scale + sx, y + row * scale + sy, colour);
            }
        }
    }
}

void drawColorBar(Image& image, int x, int y, int width, int height, ColorBy quantity,
                  const std::array<double, 2>& range) {
    const Rgb ink = {0.08f, 0.08f, 0.1f};
    for (int i = -1; i <= width; ++i) {
        const Rgb c = (i < 0 || i == width)
                          ? ink
                          : colorMap(quantity, static_cast<float>(i) / std::max(1, width - 1));
        for (int j = -1; j <= height; ++j)
            image.set(x + i, y + j, (j < 0 || j == height) ? ink : c);
    }
    const int scale = 2, glyphHeight = 7 * scale;
    drawText(image, x, y - glyphHeight - 6, quantityLabel(quantity), ink, scale);
    drawText(image, x, y + height + 5, shortNumber(range[0]), ink, scale);
    const std::string hi = shortNumber(range[1]);
    drawText(image, x + width - static_cast<int>(hi.size()) * 6 * scale, y + height + 5, hi, ink,
             scale);
}

Image contactSheet(const std::vector<Image>& frames, int columns, double scale) {
    if (frames.empty()) return Image();
    columns = std::max(1, std::min<int>(columns, static_cast<int>(frames.size())));
    const int rows = (static_cast<int>(frames.size()) + columns - 1) / columns;
    const int tileW = std::max(1, static_cast<int>(frames[0].width * scale));
    const int tileH = std::max(1, static_cast<int>(frames[0].height * scale));
    const int gap = 4;
    Image sheet(columns * tileW + (columns + 1) * gap, rows * tileH + (rows + 1) * gap,
                {255, 255, 255});
    for (std::size_t f = 0; f < frames.size(); ++f) {
        const Image& src = frames[f];
        const int ox = gap + static_cast<int>(f % columns) * (tileW + gap);
        const int oy = gap + static_cast<int>(f / columns) * (tileH + gap);
        // Box filter: each tile pixel averages the source pixels it covers (no aliasing).
        for (int ty = 0; ty < tileH; ++ty) {
            const int y0 = ty * src.height / tileH,
                      y1 = std::max(y0 + 1, (ty + 1) * src.height / tileH);
            for (int tx = 0; tx < tileW; ++tx) {
                const int x0 = tx * src.width / tileW,
                          x1 = std::max(x0 + 1, (tx + 1) * src.width / tileW);
                unsigned sum[3] = {0, 0, 0};
                for (int sy = y0; sy < y1; ++sy)
                    for (int sx = x0; sx < x1; ++sx)
                        for (int k = 0; k < 3; ++k) sum[k] += src.pixel(sx, sy)[k];
                const unsigned n = unsigned(y1 - y0) * unsigned(x1 - x0);
                std::uint8_t* p = sheet.pixel(ox + tx, oy + ty);
                for (int k = 0; k < 3; ++k) p[k] = static_cast<std::uint8_t>((sum[k] + n / 2) / n);
            }
        }
    }
    return sheet;
}

} // namespace firn
