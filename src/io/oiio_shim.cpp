// Small C ABI over OpenImageIO for pmrender: write float EXR with named channels, write 8-bit PNG,
// read an image as float RGB. Errors are returned as text in a caller-provided buffer.
// No C++ exception may cross into Rust (that aborts the process): every extern "C" entry runs its body
// inside guarded(), which turns any exception (std::bad_alloc included) into an error code and message.
#include <OpenImageIO/imageio.h>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

using namespace OIIO;

static void set_err(char* err, size_t n, const std::string& msg) {
    if (!err || n == 0) return;
    std::strncpy(err, msg.c_str(), n - 1);
    err[n - 1] = 0;
}

// Runs body() and returns its code; an exception becomes code 1 with its message in err.
template <typename F>
static int guarded(char* err, size_t errlen, F body) noexcept {
    try {
        return body();
    } catch (const std::bad_alloc&) {
        set_err(err, errlen, "out of memory");
    } catch (const std::exception& e) {
        try {
            set_err(err, errlen, std::string("OpenImageIO: ") + e.what());
        } catch (...) {
            set_err(err, errlen, "OpenImageIO: error");
        }
    } catch (...) {
        set_err(err, errlen, "OpenImageIO: unknown exception");
    }
    return 1;
}

extern "C" int pm_write_image(const char* path, int width, int height, int nchannels,
                              const char* const* names, const void* data, int is_u8,
                              char* err, size_t errlen) {
    return guarded(err, errlen, [&]() -> int {
    auto out = ImageOutput::create(path);
    if (!out) {
        set_err(err, errlen, OIIO::geterror());
        return 1;
    }
    TypeDesc type = is_u8 ? TypeDesc::UINT8 : TypeDesc::FLOAT;
    ImageSpec spec(width, height, nchannels, type);
    spec.channelnames.clear();
    for (int c = 0; c < nchannels; ++c) spec.channelnames.push_back(names[c]);
    if (!is_u8) spec.attribute("compression", "zip");
    // No timestamp: the same render must give byte-identical files.
    spec.attribute("DateTime", "");
    if (!out->open(path, spec)) {
        set_err(err, errlen, out->geterror());
        return 1;
    }
    if (!out->write_image(type, data)) {
        set_err(err, errlen, out->geterror());
        out->close();
        return 1;
    }
    if (!out->close()) {
        set_err(err, errlen, out->geterror());
        return 1;
    }
    return 0;
    });
}

// Reads the first subimage as float. On success *data is allocated with new[] and must be released with
// pm_free_image. Channel count is the file's.
extern "C" int pm_read_image(const char* path, int* width, int* height, int* nchannels, float** data,
                             char* err, size_t errlen) {
    return guarded(err, errlen, [&]() -> int {
    auto in = ImageInput::open(path);
    if (!in) {
        set_err(err, errlen, OIIO::geterror());
        return 1;
    }
    const ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 ||
        (long long)spec.width * spec.height * spec.nchannels > (1LL << 31)) {
        set_err(err, errlen, "image has an unsupported size");
        return 1;
    }
    size_t n = (size_t)spec.width * spec.height * spec.nchannels;
    // Owned until handed over, so an exception while reading frees it.
    std::unique_ptr<float[]> buf(new float[n]);
    if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, buf.get())) {
        set_err(err, errlen, in->geterror());
        return 1;
    }
    in->close();
    *width = spec.width;
    *height = spec.height;
    *nchannels = spec.nchannels;
    *data = buf.release();
    return 0;
    });
}

// Channel names of the first subimage, joined with '\n'.
extern "C" int pm_image_channels(const char* path, char* names, size_t len, char* err, size_t errlen) {
    return guarded(err, errlen, [&]() -> int {
    auto in = ImageInput::open(path);
    if (!in) {
        set_err(err, errlen, OIIO::geterror());
        return 1;
    }
    std::string all;
    for (auto& c : in->spec().channelnames) all += c + "\n";
    set_err(names, len, all);
    return 0;
    });
}

extern "C" void pm_free_image(float* data) noexcept { delete[] data; }
