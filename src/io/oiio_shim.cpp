// Small C ABI over OpenImageIO for pmrender: write float EXR with named channels, write 8-bit PNG,
// read an image as float RGB. Errors are returned as text in a caller-provided buffer; no C++ exception
// crosses into Rust (each entry catches them and reports an error).
#include <OpenImageIO/imageio.h>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

using namespace OIIO;

static void set_err(char* err, size_t n, const std::string& msg) {
    if (!err || n == 0) return;
    std::strncpy(err, msg.c_str(), n - 1);
    err[n - 1] = 0;
}

// libpng prints its errors on stderr before OpenImageIO reports them: while an input is opened or read,
// stderr goes to a temporary file, whose text ends up in the error message instead.
class StderrCapture {
    FILE* tmp_ = std::tmpfile();
    int saved_ = -1;

public:
    StderrCapture() {
        std::fflush(stderr);
        if (tmp_ && (saved_ = dup(2)) >= 0) dup2(fileno(tmp_), 2);
    }
    // Restores stderr and returns what was written to it meanwhile.
    std::string finish() {
        std::string text;
        if (saved_ < 0) return text;
        std::fflush(stderr);
        dup2(saved_, 2);
        close(saved_);
        saved_ = -1;
        std::rewind(tmp_);
        char buf[512];
        size_t n;
        while ((n = std::fread(buf, 1, sizeof buf, tmp_)) > 0 && text.size() < 4096) text.append(buf, n);
        return text;
    }
    ~StderrCapture() {
        finish();
        if (tmp_) std::fclose(tmp_);
    }
};

// The reader's error, else OpenImageIO's global one, else what the image library printed.
static std::string input_error(ImageInput* in, StderrCapture& capture) {
    std::string msg = in ? in->geterror() : std::string();
    std::string global = OIIO::geterror();
    std::string printed = capture.finish();
    if (msg.empty()) msg = global;
    if (msg.empty()) msg = printed;
    return msg.empty() ? std::string("unknown image error") : msg;
}

// Runs `body`, turning any C++ exception into an error return.
template <class F> static int guarded(char* err, size_t errlen, F body) {
    try {
        return body();
    } catch (const std::bad_alloc&) {
        set_err(err, errlen, "out of memory");
    } catch (const std::exception& e) {
        set_err(err, errlen, e.what());
    } catch (...) {
        set_err(err, errlen, "unknown C++ exception");
    }
    return 1;
}

extern "C" int pm_write_image(const char* path, int width, int height, int nchannels,
                              const char* const* names, const void* data, int is_u8,
                              char* err, size_t errlen) {
    return guarded(err, errlen, [&] {
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
    return guarded(err, errlen, [&] {
        StderrCapture capture;
        auto in = ImageInput::open(path);
        if (!in) {
            set_err(err, errlen, input_error(nullptr, capture));
            return 1;
        }
        const ImageSpec spec = in->spec();
        if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 ||
            (long long)spec.width * spec.height * spec.nchannels > (1LL << 31)) {
            set_err(err, errlen, "image has an unsupported size");
            return 1;
        }
        std::unique_ptr<float[]> buf(new float[(size_t)spec.width * spec.height * spec.nchannels]);
        if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, buf.get())) {
            set_err(err, errlen, input_error(in.get(), capture));
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

// The size of the first subimage from the file's header, without decoding pixels.
extern "C" int pm_image_size(const char* path, int* width, int* height, int* nchannels, char* err, size_t errlen) {
    return guarded(err, errlen, [&] {
        StderrCapture capture;
        auto in = ImageInput::open(path);
        if (!in) {
            set_err(err, errlen, input_error(nullptr, capture));
            return 1;
        }
        *width = in->spec().width;
        *height = in->spec().height;
        *nchannels = in->spec().nchannels;
        return 0;
    });
}

// Channel names of the first subimage, joined with '\n'.
extern "C" int pm_image_channels(const char* path, char* names, size_t len, char* err, size_t errlen) {
    return guarded(err, errlen, [&] {
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

extern "C" void pm_free_image(float* data) { delete[] data; }
