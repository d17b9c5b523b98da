#pragma once
// Annotated stills: the box file of the MSL dataset (and our own in its format), one box a line,
//   image class_id class_name x0 y0 x1 y1 [cu cv w h]
// pixels, class ids and names of obj.names (0 ball, 1 obstacle, 2 human, 3 parking, 4 goal_post or
// "goal post"; a name may hold spaces). A line with the image name alone lists an image without
// boxes. '#' starts a comment line. Every mistake is refused with the file, the line and what was
// wrong.
#include <string>
#include <vector>

namespace bv::cli {

struct AnnotatedBox {
  int class_id = 0;  // 0 = ball
  float u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  int line = 0;
};

struct AnnotatedImage {
  std::string name;  // as in the file
  std::string path;  // image_dir/name
  std::vector<AnnotatedBox> boxes;
  int line = 0;  // first line naming it
  int BallCount() const;
};

/// Images in file order of first appearance. False with `error` for an unreadable or empty file,
/// a malformed line, an unknown class (id outside 0..4 or a name that is not the id's), or a box
/// with x1 < x0 or y1 < y0.
bool LoadAnnotations(const std::string& file, const std::string& image_dir,
                     std::vector<AnnotatedImage>& out, std::string& error);

/// Adds the boxes of `file` (a box file of the same format: boxes the first file lacks) to the
/// images of `images`. False with `error` for what LoadAnnotations refuses, or for an image that
/// `images` does not hold (file, line, image); `images` is unchanged then.
bool AddAnnotations(const std::string& file, std::vector<AnnotatedImage>& images,
                    std::string& error);

/// False with `error` (file, line, box) when a box lies outside a width x height image by more
/// than one pixel.
bool CheckBoxesInside(const std::string& file, const AnnotatedImage& image, int width, int height,
                      std::string& error);

/// The set an image belongs to: its name up to the second '_' (date_robot in the MSL dataset), or
/// the whole name without extension when it has fewer.
std::string ImageSet(const std::string& name);

/// The images of `split`: "all", "even" or "odd" (by position in `images`, 0 even).
std::vector<AnnotatedImage> SplitImages(const std::vector<AnnotatedImage>& images,
                                        const std::string& split);

}  // namespace bv::cli
