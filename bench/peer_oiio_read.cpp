// SPDX-License-Identifier: MIT
// The peer of the `image` node's read time in bench/run_io.sh: OpenImageIO's ImageInput reading
// a whole file as float (read_image, all channels, unassociated alpha as wetgraph asks for),
// timed from open to close, median of REPS runs in milliseconds. The library is loaded and its
// plugins initialised by a first, untimed read, so the time is the read alone, as the node's
// time from --stats is.
// Usage: peer_oiio_read FILE [REPS]
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

using namespace OIIO;

static double read_once(const char *path)
{
    auto t0 = std::chrono::steady_clock::now();
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = ImageInput::open(path, &config);
    if (!in) {
        std::fprintf(stderr, "peer_oiio_read: %s: %s\n", path, OIIO::geterror().c_str());
        std::exit(1);
    }
    const ImageSpec &spec = in->spec();
    std::vector<float> pixels((size_t)spec.width * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, pixels.data())) {
        std::fprintf(stderr, "peer_oiio_read: %s: %s\n", path, in->geterror().c_str());
        std::exit(1);
    }
    in->close();
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
        .count();
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: peer_oiio_read FILE [REPS]\n");
        return 2;
    }
    int reps = argc > 2 ? std::atoi(argv[2]) : 5;
    read_once(argv[1]);
    std::vector<double> t;
    for (int i = 0; i < reps; i++) t.push_back(read_once(argv[1]));
    std::sort(t.begin(), t.end());
    std::printf("%.1f\n", t[t.size() / 2]);
    return 0;
}
