// The released GSM configuration built in; see gsm_preset.h. The text below is
// assets/models/infinicube-gsm.json verbatim (tests/nn/test_gsm_params.cpp compares them).
#include "nn/gsm/gsm_preset.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"

namespace icube::nn {

namespace {

const char* const kInfinicubeGsmJson = R"json({
 "preset": "infinicube-gsm",
 "source": "nv-tlabs/InfiniCube voxelgen/configs/gsm_vs02_res512_view1_dual_branch_sky_mlp_modulator.yaml over default/param.yaml, train/gsm/gsm.yaml, train/gsm/dual_branch_backbone.yaml and dataset.yaml, merged as voxelgen/utils/exp.py parse_config_yaml does with ${...} resolved, plus the keys hparams_handler adds; dav2_config: the Depth-Anything-V2-Large architecture (DINOv2 ViT-L/14)",
 "hparams": {
  "test_set_shuffle": false,
  "batch_size": 1,
  "accumulate_grad_batches": 4,
  "visualize": false,
  "name": "release/waymo_wds",
  "tree_depth": 4,
  "voxel_size": 0.1,
  "duplicate_num": 1,
  "pin_memory": false,
  "keep_surface_voxels": false,
  "clip_input_grid": false,
  "coarsen_input_grid": false,
  "voxel_maximum": -1,
  "render_alpha": true,
  "render_weight": 1.0,
  "alpha_weight": 1.0,
  "depth_weight": 5,
  "render_background": "black",
  "perceptual_weight": 0.5,
  "use_ssim_loss": true,
  "perceptual_start_epoch": 0,
  "use_input_color": false,
  "gsplat_upsample": 1,
  "gs_free_space": "hard",
  "use_alex_metric": true,
  "gsplat_params": {
   "radius_clip": 0.0,
   "rasterize_mode": "classic",
   "absgrad": false,
   "force_float32": true
  },
  "use_checkpoint": false,
  "supervision": {
   "structure_weight": 0.0,
   "render_weight": 1.0,
   "alpha_weight": 1.0,
   "depth_weight": 5,
   "depth_supervision_format": "weight",
   "z_near": 0.5,
   "z_far": 300
  },
  "optimizer": "Adam",
  "learning_rate": {
   "init": 0.0001,
   "decay_mult": 1.0,
   "decay_step": 2000000000,
   "clip": 1e-06
  },
  "weight_decay": 0.0,
  "grad_clip": 0.5,
  "renderer": {
   "target": "RGBRenderer"
  },
  "rasterizing_downsample": 1,
  "log_gaussian_stats": true,
  "only_sup_foreground": false,
  "render_target_is_object": false,
  "model": "gsm",
  "backbone": {
   "target": "DualBranchUNet",
   "params": {
    "use_3d": true,
    "use_2d": true,
    "backbone_3d_target": "Pure3DUnet",
    "backbone_3d_params": {
     "lifter_params": {
      "img_feature_source": "conv",
      "img_in_dim": 64,
      "voxel_out_dim": 64
     },
     "img_feature_source": "conv",
     "in_channels": 64,
     "num_blocks": 3,
     "f_maps": 64,
     "f_maps_2d": 64,
     "neck_dense_type": "UNCHANGED",
     "neck_bound": [
      128,
      128,
      32
     ],
     "use_attention": false,
     "gs_enhanced": "original",
     "gsplat_upsample": 4,
     "occ_upsample": 2,
     "max_scaling": 1,
     "max_return": 1,
     "feature_pooling_2d": "max"
    },
    "backbone_2d_params": {
     "znear": 0.5,
     "zfar": 300,
     "max_scale": 0.1,
     "interpret_output_depth": "weight",
     "feature_source": "original_rgb",
     "concat_depth_priors": [
      "dav2_feature",
      "masked_voxel_depth"
     ],
     "masked_voxel_depth_params": {
      "patch_size": 16,
      "mask_prob": 0.5
     },
     "gs_per_pixel": 2,
     "gs_dim": 12,
     "unet2d_params": {
      "channels": 36,
      "init_dim": 32,
      "dim": 32,
      "out_dim": 24,
      "dim_mults": [
       1,
       2,
       4,
       8
      ],
      "num_blocks_per_stage": [
       2,
       2,
       2,
       2
      ],
      "num_self_attn_per_stage": [
       0,
       0,
       0,
       0
      ],
      "consolidate_upsample_fmaps": true
     }
    },
    "pretrain_3d_branch_ckpt": "",
    "pretrain_2d_branch_ckpt": ""
   }
  },
  "_wds_root_url": "data/",
  "_dino_slect_ids": null,
  "_dino_data_root": null,
  "_n_image_per_iter_sup": 9,
  "use_fvdb_loader": true,
  "shuffle_buffer": 1000,
  "_add_high_res_grid": false,
  "_attr_subfolders": [
   "pose",
   "pc_voxelsize_01",
   "intrinsic",
   "static_object_info",
   "dynamic_object_info",
   "dynamic_object_points_canonical",
   "image_480p_front",
   "skymask_480p_front",
   "3d_road_edge_voxelsize_025",
   "3d_road_line_voxelsize_025",
   "3d_road_surface_voxelsize_04"
  ],
  "_fvdb_grid_type": "vs02",
  "finest_voxel_size_goal": "vs02",
  "grid_crop_bbox_min": [
   0,
   -40,
   -12.8
  ],
  "grid_crop_bbox_max": [
   153.6,
   40,
   38.4
  ],
  "input_depth_type": null,
  "map_types": null,
  "frame_start_num": 15,
  "frame_end_num": 155,
  "grid_crop_augment": false,
  "grid_crop_augment_range": [
   12.8,
   12.8,
   3.2
  ],
  "add_road_line_to_GT": false,
  "replace_all_car_with_cad": false,
  "train_dataset": "WaymoWdsDataset",
  "train_val_num_workers": 16,
  "train_kwargs": {
   "split": "train",
   "wds_root_url": "data/",
   "wds_scene_list_file": "infinicube/assets/waymo_split/official_train_static_scene.json",
   "attr_subfolders": [
    "pose",
    "pc_voxelsize_01",
    "intrinsic",
    "static_object_info",
    "dynamic_object_info",
    "dynamic_object_points_canonical",
    "image_480p_front",
    "skymask_480p_front",
    "3d_road_edge_voxelsize_025",
    "3d_road_line_voxelsize_025",
    "3d_road_surface_voxelsize_04"
   ],
   "grid_crop_bbox_min": [
    0,
    -40,
    -12.8
   ],
   "grid_crop_bbox_max": [
    153.6,
    40,
    38.4
   ],
   "grid_crop_augment": false,
   "grid_crop_augment_range": [
    12.8,
    12.8,
    3.2
   ],
   "frame_start_num": 15,
   "frame_end_num": 155,
   "dino_slect_ids": null,
   "dino_data_root": null,
   "input_slect_ids": [
    0
   ],
   "input_frame_offsets": [
    0,
    10,
    20,
    30
   ],
   "input_depth_type": null,
   "sup_slect_ids": [
    0
   ],
   "sup_frame_offsets": [
    0,
    2,
    5,
    7,
    10,
    12,
    15,
    17,
    20,
    22,
    25,
    27,
    30,
    32,
    35,
    37,
    40
   ],
   "n_image_per_iter_sup": 9,
   "fvdb_grid_type": "vs02",
   "finest_voxel_size_goal": "vs02",
   "shuffle_buffer": 1000,
   "add_high_res_grid": false,
   "map_types": null,
   "add_road_line_to_GT": false,
   "replace_all_car_with_cad": false
  },
  "val_dataset": "WaymoWdsDataset",
  "val_kwargs": {
   "split": "val",
   "wds_root_url": "data/",
   "wds_scene_list_file": "infinicube/assets/waymo_split/official_val_static_scene.json",
   "attr_subfolders": [
    "pose",
    "pc_voxelsize_01",
    "intrinsic",
    "static_object_info",
    "dynamic_object_info",
    "dynamic_object_points_canonical",
    "image_480p_front",
    "skymask_480p_front",
    "3d_road_edge_voxelsize_025",
    "3d_road_line_voxelsize_025",
    "3d_road_surface_voxelsize_04"
   ],
   "grid_crop_bbox_min": [
    0,
    -40,
    -12.8
   ],
   "grid_crop_bbox_max": [
    153.6,
    40,
    38.4
   ],
   "frame_start_num": 15,
   "frame_end_num": 155,
   "dino_slect_ids": null,
   "dino_data_root": null,
   "input_slect_ids": [
    0
   ],
   "input_frame_offsets": [
    0,
    10,
    20,
    30
   ],
   "input_depth_type": null,
   "sup_slect_ids": [
    0
   ],
   "sup_frame_offsets": [
    0,
    2,
    5,
    7,
    10,
    12,
    15,
    17,
    20,
    22,
    25,
    27,
    30,
    32,
    35,
    37,
    40
   ],
   "n_image_per_iter_sup": 9,
   "fvdb_grid_type": "vs02",
   "finest_voxel_size_goal": "vs02",
   "shuffle_buffer": 1000,
   "add_high_res_grid": false,
   "map_types": null,
   "add_road_line_to_GT": false,
   "replace_all_car_with_cad": false
  },
  "test_dataset": "WaymoWdsDataset",
  "test_num_workers": 4,
  "test_kwargs": {
   "split": "test",
   "wds_root_url": "data/",
   "wds_scene_list_file": "infinicube/assets/waymo_split/official_val_static_scene.json",
   "attr_subfolders": [
    "pose",
    "pc_voxelsize_01",
    "intrinsic",
    "static_object_info",
    "dynamic_object_info",
    "dynamic_object_points_canonical",
    "image_480p_front",
    "skymask_480p_front",
    "3d_road_edge_voxelsize_025",
    "3d_road_line_voxelsize_025",
    "3d_road_surface_voxelsize_04"
   ],
   "grid_crop_bbox_min": [
    0,
    -40,
    -12.8
   ],
   "grid_crop_bbox_max": [
    153.6,
    40,
    38.4
   ],
   "frame_start_num": 15,
   "frame_end_num": 155,
   "dino_slect_ids": null,
   "dino_data_root": null,
   "input_slect_ids": [
    0
   ],
   "input_frame_offsets": [
    0,
    10,
    20,
    30
   ],
   "input_depth_type": null,
   "sup_slect_ids": [
    0
   ],
   "sup_frame_offsets": [
    0,
    2,
    5,
    7,
    10,
    12,
    15,
    17,
    20,
    22,
    25,
    27,
    30,
    32,
    35,
    37,
    40
   ],
   "n_image_per_iter_sup": 9,
   "fvdb_grid_type": "vs02",
   "finest_voxel_size_goal": "vs02",
   "shuffle_buffer": 1000,
   "add_high_res_grid": false,
   "map_types": null,
   "add_road_line_to_GT": false,
   "replace_all_car_with_cad": false
  },
  "_input_slect_ids": [
   0
  ],
  "_input_frame_offsets": [
   0,
   10,
   20,
   30
  ],
  "_sup_slect_ids": [
   0
  ],
  "_sup_frame_offsets": [
   0,
   2,
   5,
   7,
   10,
   12,
   15,
   17,
   20,
   22,
   25,
   27,
   30,
   32,
   35,
   37,
   40
  ],
  "sup_depth_type": "voxel_depth",
  "encoder": {
   "resize_projection_input": false,
   "encoder_modules": [
    "conv",
    "dav2"
   ],
   "conv_params": {
    "n_filter_list": [
     3,
     16,
     32,
     64
    ],
    "n_stride_list": [
     1,
     1,
     1
    ],
    "n_kernel_list": [
     3,
     3,
     3
    ],
    "n_padding_list": [
     1,
     1,
     1
    ],
    "n_residual_list": [
     false,
     true,
     true
    ],
    "n_use_gn_list": [
     false,
     false,
     false
    ],
    "conv_encoder_out_dim": 64
   },
   "dav2_params": {
    "depth_anything_model": "depth-anything/Depth-Anything-V2-Large-hf",
    "model_freeze": true,
    "target_input_size": [
     280,
     420
    ],
    "out_dim_list": [
     128,
     32
    ],
    "out_upsample_list": [
     true,
     true
    ],
    "out_downsample_list": [
     false,
     false
    ],
    "out_use_gn_list": [
     false,
     false
    ]
   }
  },
  "model_midground": true,
  "use_skybox": true,
  "skybox_target": "mlp_modulator",
  "skybox_feature_source": "original_rgb",
  "skybox_forward_sky_only": true,
  "skybox_net": "decode-3",
  "skybox_mlp_modulator": {
   "patch_size": 16,
   "num_heads": 4,
   "embed_dim": 192,
   "hidden_channels": 192,
   "out_channels": 3,
   "sky_token_encoding_type": "transformer",
   "sky_image_embedder_type": "mlp",
   "modulator_pos_embedding": "mlp",
   "transformer": {
    "num_layers": 4,
    "dim_feedforward": 384,
    "activation": "gelu"
   }
  },
  "perceputal_resize_height": 480,
  "supervise_image_resize": [
   480,
   832
  ],
  "keep_surface_voxel": false,
  "use_high_res_grid_for_alpha_mask": false,
  "skybox_type": "panorama_full",
  "skybox_resolution": 1024,
  "with_render_branch": true,
  "pixel_loss": "l1",
  "use_sup_depth": true,
  "gt_alpha_from": "grid"
 },
 "dav2_config": {
  "backbone_config": {
   "mlp_ratio": 4,
   "hidden_act": "gelu",
   "layer_norm_eps": 1e-06,
   "image_size": 518,
   "patch_size": 14,
   "num_channels": 3,
   "qkv_bias": true,
   "layerscale_value": 1.0,
   "drop_path_rate": 0.0,
   "use_swiglu_ffn": false,
   "apply_layernorm": true,
   "reshape_hidden_states": false,
   "use_mask_token": true,
   "hidden_dropout_prob": 0.0,
   "attention_probs_dropout_prob": 0.0,
   "initializer_range": 0.02,
   "hidden_size": 1024,
   "num_hidden_layers": 24,
   "num_attention_heads": 16,
   "out_indices": [
    5,
    12,
    18,
    24
   ]
  },
  "patch_size": 14,
  "reassemble_factors": [
   4,
   2,
   1,
   0.5
  ],
  "head_in_index": -1,
  "depth_estimation_type": "relative",
  "max_depth": null,
  "initializer_range": 0.02,
  "neck_hidden_sizes": [
   256,
   512,
   1024,
   1024
  ],
  "fusion_hidden_size": 256,
  "head_hidden_size": 32,
  "reassemble_hidden_size": 1024
 }
}
)json";

}  // namespace

const std::string& infinicube_gsm_config_text() {
  static const std::string text(kInfinicubeGsmJson);
  return text;
}

GsmConfigJson read_gsm_config_json(const std::string& name_or_path) {
  GsmConfigJson out;
  const bool preset = name_or_path == kInfinicubeGsmPreset;
  out.source = preset ? std::string("preset ") + kInfinicubeGsmPreset : name_or_path;
  try {
    out.json = nlohmann::json::parse(preset ? infinicube_gsm_config_text() : scene::read_file(name_or_path));
  } catch (const nlohmann::json::exception& e) {
    throw scene::InputError(out.source, "", std::string("not JSON: ") + e.what());
  }
  if (!out.json.is_object()) throw scene::InputError(out.source, "", "is not a JSON object");
  return out;
}

GsmConfig load_gsm_config(const std::string& name_or_path) {
  const GsmConfigJson j = read_gsm_config_json(name_or_path);
  return gsm_config_from_json(j.json, j.source);
}

}  // namespace icube::nn
