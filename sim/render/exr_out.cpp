#include "sim/render/exr_out.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include "sim/core/error.h"

namespace nvs::render {

void writeRadianceExr(const std::filesystem::path& path, ImageView<const float> img,
                      const std::vector<std::pair<std::string, std::string>>& attributes) {
    try {
        Imf::Header hdr(img.width(), img.height());
        hdr.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        for (const auto& [k, v] : attributes)
            hdr.insert(k, Imf::StringAttribute(v));
        {
            Imf::OutputFile file(path.c_str(), hdr);
            Imf::FrameBuffer fb;
            fb.insert("Y", Imf::Slice(Imf::FLOAT,
                                      const_cast<char*>(reinterpret_cast<const char*>(img.row(0))),
                                      sizeof(float),
                                      sizeof(float) * static_cast<std::size_t>(img.stride_px())));
            file.setFrameBuffer(fb);
            file.writePixels(img.height());
        }
    } catch (const std::exception& e) {
        throw SetupError(path.string() + ": cannot write EXR: " + e.what());
    }
}

ImageF readRadianceExr(const std::filesystem::path& path,
                       std::vector<std::pair<std::string, std::string>>* attributes) {
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& hdr = file.header();
        const auto dw = hdr.dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        ImageF img(w, h);
        Imf::FrameBuffer fb;
        fb.insert("Y",
                  Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(img.view().row(0)), sizeof(float),
                             sizeof(float) * static_cast<std::size_t>(img.view().stride_px())));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (attributes != nullptr) {
            for (auto it = hdr.begin(); it != hdr.end(); ++it) {
                if (const auto* a = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) {
                    attributes->emplace_back(it.name(), a->value());
                }
            }
        }
        return img;
    } catch (const std::exception& e) {
        throw SetupError(path.string() + ": cannot read EXR: " + e.what());
    }
}

}  // namespace nvs::render
