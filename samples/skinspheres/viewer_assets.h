// The viewer page's source (viewer/ in the repository) and the three.js scripts it inlines
// (Debian's libjs-three), compiled into the tool by cmake/EmbedFiles.cmake (viewer_assets.cc in
// the build tree). SKINSPHERES_THREE_REVISION (a compile definition) is three.js's REVISION.
#pragma once

#include <string_view>

namespace skinspheres::tool::viewer_assets {

extern const std::string_view kIndexHtml;        // viewer/index.html: the template
extern const std::string_view kViewerCss;        // viewer/viewer.css
extern const std::string_view kViewerJs;         // viewer/viewer.js
extern const std::string_view kThreeLicense;     // viewer/THREE_LICENSE.txt
extern const std::string_view kThreeJs;          // three.min.js
extern const std::string_view kGltfLoaderJs;     // examples/js/loaders/GLTFLoader.js
extern const std::string_view kOrbitControlsJs;  // examples/js/controls/OrbitControls.js

}  // namespace skinspheres::tool::viewer_assets
