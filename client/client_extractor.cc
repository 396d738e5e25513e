#include "client/client_extractor.h"

#include "common/config/config.h"
#include "common/map/map_io.h"

namespace sceneloc {

StatusOr<ClientExtractor> ClientExtractor::Create(const ClientExtractorSource& source) {
  ClientExtractor out;
  TrainOptions options;
  if (!source.map_file.empty()) {
    if (source.working_size > 0) {
      return InvalidArgument("a working size cannot override a map file's own frame");
    }
    SCENELOC_ASSIGN_OR_RETURN(const Map map, LoadMap(source.map_file));
    options = map.options;
    out.has_map_frame_ = true;
    out.map_width_ = map.image_width;
    out.map_grid_ = map.holistic_grid;
  } else if (!source.config.empty()) {
    SCENELOC_RETURN_IF_ERROR(LoadTrainOptions(source.config, &options));
  }
  if (source.working_size > 0) options.extractor.working_size = source.working_size;
  SCENELOC_RETURN_IF_ERROR(options.extractor.Validate());
  out.extractor_ = FeatureExtractor::Create(options.extractor);
  return out;
}

StatusOr<FeatureSet> ClientExtractor::Extract(const cv::Mat& image) const {
  if (!has_map_frame_) return extractor_->ExtractTour(image);
  if (image.empty()) return InvalidArgument("empty image");
  return extractor_->Extract(image, QueryTarget(image.cols, image.rows, map_width_, map_grid_));
}

}  // namespace sceneloc
